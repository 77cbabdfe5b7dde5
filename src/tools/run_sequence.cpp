// run_sequence: the whole SLAM offline, in one process (tracking on this thread, the window BA and
// the loop closure on their own threads), on a TUM, EuRoC or KITTI folder or a rosbag. Writes
// DIR/trajectory.txt (every tracked frame, corrected by the loop closures, TUM, T_world_cam),
// DIR/trajectory_as_tracked.txt (the poses as they were output live), DIR/keyframes.txt (the
// mapper's final keyframes, TUM), DIR/keyframes_before_loop_N.txt (the keyframes just before the
// N-th loop correction), DIR/frames.csv (each frame's tracking state, counts and message) and
// DIR/summary.json (counts, loops, per-stage timing, memory).

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "scale_drift_slam/common/stopwatch.h"
#include "scale_drift_slam/io/calibration_io.h"
#include "scale_drift_slam/io/command_line.h"
#include "scale_drift_slam/io/image_sequence.h"
#include "scale_drift_slam/io/map_file.h"
#include "scale_drift_slam/io/run_statistics.h"
#include "scale_drift_slam/io/slam_params_io.h"
#include "scale_drift_slam/io/trajectory_io.h"
#include "scale_drift_slam/ros/bag_image_sequence.h"
#include "scale_drift_slam/system/slam_system.h"

namespace {

using namespace scale_drift_slam;
namespace fs = std::filesystem;

const char* const kUsage =
    R"(usage: run_sequence DATASET --out DIR [--calib FILE] [--config FILE] [options]

Runs the monocular SLAM offline on DATASET: a TUM folder (rgb.txt [+ camera.yaml]), an EuRoC
folder (mav0/cam0/data.csv + sensor.yaml), a KITTI odometry folder (image_0/, times.txt,
calib.txt) or a rosbag (*.bag).
  --out DIR            output folder: trajectory.txt (corrected by loop closures),
                       trajectory_as_tracked.txt, keyframes.txt (TUM), frames.csv,
                       summary.json, keyframes_before_loop_N.txt (the keyframes just
                       before the N-th loop correction, TUM)
  --calib FILE         calibration YAML (default: the dataset's own, or the bag's CameraInfo)
  --config FILE        SLAM parameters (default: built-in defaults = config/default.yaml)
  --topic NAME         bag image topic (default /camera/image_raw)
  --camera-info-topic NAME   bag CameraInfo topic (default /camera/camera_info)
  --max-frames N       stop after N frames (default: all)
  --se3                correct loops with the SE(3) pose graph (the paper's baseline)
  --no-loop-closure    no loop closure (relocalisation still works)
  --save-map FILE      save the map at the end (doc/map_file.md)
  --load-map FILE      start in a saved map: relocalise in it by place recognition, write the
                       trajectory in its frame, and extend it (new keyframes, loops)
  --localization       with --load-map: localise only, add no keyframe, leave the map as it is
  --quiet              no progress bar, no parameter dump
)";

std::unique_ptr<io::ImageSequence> openDataset(const io::CommandLine& args,
                                               const std::string& dataset) {
  if (fs::path(dataset).extension() == ".bag") {
    return ros_conversions::openBagImageSequence(
        dataset, args.text("topic", "/camera/image_raw"),
        args.text("camera-info-topic", "/camera/camera_info"));
  }
  return io::openImageFolder(dataset);
}

void printProgress(std::size_t done, std::size_t total, const tracking::FrameResult& r) {
  const int width = 30;
  const double share = total ? static_cast<double>(done) / total : 0.0;
  const int filled = std::min(width, static_cast<int>(share * width));
  std::fprintf(stderr, "\r[%s%s] %zu/%zu %-12s", std::string(filled, '=').c_str(),
               std::string(width - filled, ' ').c_str(), done, total,
               trackingStateName(r.state).c_str());
}

std::vector<io::StampedPose> keyframePoses(const map::Map& map) {
  std::vector<io::StampedPose> poses;
  for (const auto& [id, keyframe] : map.keyframes()) {
    poses.push_back({keyframe.timestamp, keyframe.T_kf_world.inverse()});
  }
  return poses;
}

tracking::FrameResult processOne(system::SlamSystem& slam, const io::SequenceFrame& frame) {
  try {
    const features::PixelEncoding encoding = frame.encoding.empty()
                                                 ? features::encodingOfMat(frame.image)
                                                 : features::parsePixelEncoding(frame.encoding);
    return slam.processFrame(frame.timestamp, frame.image, encoding);
  } catch (const std::invalid_argument& e) {  // empty or unsupported image: skip the frame
    tracking::FrameResult r;
    r.rejected = true;
    r.message = std::string("frame rejected: ") + (frame.image.empty() ? "unreadable" : e.what());
    return r;
  }
}

void addTimes(const tracking::FrameResult& r, io::StageTimings* timings) {
  timings->add("prepare", r.times.prepare);
  if (r.state == tracking::TrackingState::kInitializing || r.keyframes.size() > 1) return;
  timings->add("flow", r.times.flow);
  timings->add("search", r.times.search);
  timings->add("motion_ba", r.times.motion_ba);
  timings->add("filters", r.times.filters);
  timings->add("keyframe", r.times.keyframe);
  timings->add("tracking_total", r.times.total);
  timings->add("tracking_cpu", r.times.cpu);
}

std::vector<io::StampedPose> correctedTrajectory(const system::SlamSystem& slam) {
  std::vector<io::StampedPose> poses;
  for (const map::CorrectedTrajectory::Frame& frame : slam.trajectory().frames())
    poses.push_back({frame.timestamp, frame.T_cam_world.inverse()});
  return poses;
}

void addBackgroundTimes(const system::SlamSystem& slam, io::StageTimings* timings) {
  const system::BackgroundTimes times = slam.backgroundTimes();
  for (const double ms : times.window_ba_ms)
    timings->add("window_ba", ms);
  for (const double ms : times.place_recognition_ms)
    timings->add("place_recognition", ms);
  for (const double ms : times.verification_ms)
    timings->add("loop_verification", ms);
  for (const double ms : times.relocalisation_ms)
    timings->add("relocalisation", ms);
  for (const mapping::LoopCorrectionStatistics& loop : slam.loops()) {
    if (loop.applied) timings->add("loop_correction", loop.total_ms);
  }
}

/// The keyframes just before the n-th applied loop's correction (TUM), in the output folder.
std::string loopSnapshotName(int n) {
  return "keyframes_before_loop_" + std::to_string(n) + ".txt";
}

/// The loops applied: keyframe ids, inliers, the measured scale and the correction's figures.
nlohmann::json loopsJson(const system::SlamSystem& slam) {
  nlohmann::json loops = nlohmann::json::array();
  for (const mapping::LoopCorrectionStatistics& loop : slam.loops()) {
    if (!loop.applied) continue;
    const loop::LoopConstraint& c = loop.constraint;
    loops.push_back({{"keyframes_before", loopSnapshotName(static_cast<int>(loops.size()))},
                     {"current_keyframe", c.current_id},
                     {"loop_keyframe", c.loop_id},
                     {"current_stamp", slam.map().keyframe(c.current_id).timestamp},
                     {"loop_stamp", slam.map().keyframe(c.loop_id).timestamp},
                     {"inliers", c.num_inliers},
                     {"matches", c.num_matches},
                     {"scale", c.scale},
                     {"scale_pairs", c.num_scale_pairs},
                     {"rmse_px", c.rmse_px},
                     {"graph_keyframes", loop.vertices},
                     {"graph_iterations", loop.graph_iterations},
                     {"graph_converged", loop.graph_converged},
                     {"graph_initial_chi2", loop.graph_initial_chi2},
                     {"graph_guess_loops", loop.graph_guess_loops},
                     {"graph_guess_chi2", loop.graph_guess_chi2},
                     {"graph_final_chi2", loop.graph_final_chi2},
                     {"graph_ms", loop.graph_ms},
                     {"structure_only_ba_ms", loop.structure_ms},
                     {"correction_ms", loop.total_ms},
                     {"correction_scale_at_current", loop.current_correction_scale},
                     {"graph_build_ms", loop.build_ms},
                     {"map_correction_ms", loop.correction_ms},
                     {"reprojection_median_px_corrected", loop.reprojection_before.median},
                     {"reprojection_median_px_refined", loop.reprojection_after.median}});
  }
  return loops;
}

/// frames.csv: one line per frame, what the tracker made of it (for plots and diagnosis).
std::ofstream openFrameLog(const fs::path& path) {
  std::ofstream file(path);
  if (!file) throw std::runtime_error("cannot write '" + path.string() + "'");
  file << "frame,timestamp,state,rejected,visible,found,inliers,keyframes,new_points,candidates,"
          "relocalised,message\n";
  return file;
}

/// `candidates`: feature candidates alive after the frame (tracking::Tracker::numCandidates).
void logFrame(int index, const io::SequenceFrame& frame, const tracking::FrameResult& r,
              std::size_t candidates, std::ofstream* file) {
  std::string message = r.message;
  std::replace(message.begin(), message.end(), '"', '\'');
  std::size_t new_points = 0;
  for (const map::KeyframeMessage& keyframe : r.keyframes)
    new_points += keyframe.new_points.size();
  *file << index << ',' << std::fixed << std::setprecision(6) << frame.timestamp << ','
        << trackingStateName(r.state) << ',' << r.rejected << ',' << r.num_visible << ','
        << r.num_found << ',' << r.num_inliers << ',' << r.keyframes.size() << ',' << new_points
        << ',' << candidates << ',' << r.relocalised << ",\"" << message << "\"\n";
}

/// What run_sequence was asked to do.
struct RunOptions {
  std::string dataset;
  fs::path out;
  long max_frames = -1;  // -1: all
  bool quiet = false;
  system::SlamParams params;
  std::string save_map, load_map;
  bool localization = false;
};

RunOptions parseOptions(const io::CommandLine& args) {
  args.rejectUnknownFlags({"out", "calib", "config", "topic", "camera-info-topic", "max-frames",
                           "quiet", "se3", "no-loop-closure", "save-map", "load-map",
                           "localization"});
  RunOptions options;
  options.dataset = args.positional(0, "DATASET");
  options.out = args.required("out");
  options.max_frames = args.integer("max-frames", -1);
  options.quiet = args.has("quiet");
  options.save_map = args.text("save-map", "");
  options.load_map = args.text("load-map", "");
  options.localization = args.has("localization");
  if (options.localization && options.load_map.empty()) {
    throw std::invalid_argument("--localization needs --load-map FILE");
  }
  system::SlamParams& params = options.params;
  if (args.has("config")) params = io::loadSlamParams(args.required("config"));
  if (args.has("se3")) params.mapper.loop_correction.graph.mode = loop::PoseGraphMode::kSE3;
  if (args.has("no-loop-closure")) params.loop.enabled = false;
  return options;
}

/// --calib, else the dataset's own calibration.
geometry::CameraCalibration calibrationOf(const io::CommandLine& args, const std::string& dataset,
                                          const io::ImageSequence& sequence) {
  if (args.has("calib")) return io::loadCalibrationYaml(args.required("calib"));
  if (sequence.calibration()) return *sequence.calibration();
  throw std::invalid_argument("'" + dataset + "' has no calibration of its own: pass --calib");
}

/// What the frame loop gathered.
struct RunTally {
  std::vector<io::StampedPose> trajectory;  // as output live
  io::StageTimings timings;
  std::map<std::string, int> states;
  int frames = 0;
  int rejected = 0;
};

/// Feeds the frames to the SLAM, logging each to frames.csv; finishes the background threads.
RunTally trackSequence(const RunOptions& options, io::ImageSequence& sequence,
                       system::SlamSystem& slam) {
  RunTally tally;
  std::ofstream frame_log = openFrameLog(options.out / "frames.csv");
  const long max_frames = options.max_frames;
  const std::size_t total =
      max_frames >= 0 ? std::min<std::size_t>(max_frames, sequence.size()) : sequence.size();
  const bool progress = !options.quiet && isatty(STDERR_FILENO);
  while (max_frames < 0 || tally.frames < max_frames) {
    const std::optional<io::SequenceFrame> frame = sequence.next();
    if (!frame) break;
    ++tally.frames;
    const common::Stopwatch frame_timer;
    const tracking::FrameResult r = processOne(slam, *frame);
    // What the camera sees: the whole call, with map updates applied (and the window BA when
    // the mapper runs inline).
    const double frame_ms = frame_timer.ms();
    if (r.rejected) {
      ++tally.rejected;
      std::cerr << (progress ? "\n" : "") << frame->source << ": " << r.message << "\n";
    } else {
      ++tally.states[trackingStateName(r.state)];
      addTimes(r, &tally.timings);
      if (r.state != tracking::TrackingState::kInitializing) tally.timings.add("frame", frame_ms);
    }
    if (r.has_pose) tally.trajectory.push_back({frame->timestamp, r.T_cam_world.inverse()});
    logFrame(tally.frames - 1, *frame, r, slam.tracker().numCandidates(), &frame_log);
    for (const std::string& line : slam.takeLog())
      std::cout << (progress ? "\n" : "") << line << "\n";
    if (progress && (tally.frames % 10 == 0 || tally.frames == static_cast<int>(total))) {
      printProgress(tally.frames, total, r);
    }
  }
  if (progress) std::fprintf(stderr, "\n");
  slam.finish();
  for (const std::string& line : slam.takeLog())
    std::cout << line << "\n";
  addBackgroundTimes(slam, &tally.timings);
  return tally;
}

/// trajectory.txt, trajectory_as_tracked.txt and keyframes.txt.
void writeTrajectories(const RunOptions& options, const system::SlamSystem& slam,
                       const RunTally& tally) {
  const fs::path& out = options.out;
  const std::string& dataset = options.dataset;
  io::saveTumTrajectory((out / "trajectory.txt").string(), correctedTrajectory(slam),
                        "every tracked frame corrected by the loop closures, T_world_cam, "
                        "run_sequence " +
                            dataset);
  io::saveTumTrajectory((out / "trajectory_as_tracked.txt").string(), tally.trajectory,
                        "every tracked frame as output live, T_world_cam, run_sequence " + dataset);
  io::saveTumTrajectory((out / "keyframes.txt").string(), keyframePoses(slam.map()),
                        "keyframes after the last window BA, T_world_cam");
  int index = 0;
  for (const mapping::LoopCorrectionStatistics& loop : slam.loops()) {
    if (!loop.applied) continue;
    std::vector<io::StampedPose> before;
    for (const auto& [stamp, T_kf_world] : loop.keyframes_before)
      before.push_back({stamp, T_kf_world.inverse()});
    io::saveTumTrajectory((out / loopSnapshotName(index++)).string(), before,
                          "keyframes just before the correction of loop " +
                              std::to_string(loop.constraint.current_id) + " -> " +
                              std::to_string(loop.constraint.loop_id) + ", T_world_cam");
  }
}

void writeSummaryJson(const RunOptions& options, const system::SlamSystem& slam,
                      const RunTally& tally, double startup_ms, double peak_mib) {
  const std::string& dataset = options.dataset;
  const nlohmann::json summary = {
      {"dataset", dataset},
      {"frames", tally.frames},
      {"rejected_frames", tally.rejected},
      {"tracked", tally.trajectory.size()},
      {"states", tally.states},
      {"keyframes", slam.map().numKeyframes()},
      {"points", slam.map().numPoints()},
      {"observations", slam.map().numObservations()},
      {"loops", loopsJson(slam)},
      {"relocalisations", slam.relocalisations()},
      {"map_restarts", slam.mapRestarts()},
      {"loaded_map_keyframes", slam.restoredKeyframes()},
      {"keyframes_added", slam.map().numKeyframes() - slam.restoredKeyframes()},
      {"timing", tally.timings.toJson()},
      {"startup_ms", startup_ms},
      {"peak_memory_mib", peak_mib}};
  std::ofstream(options.out / "summary.json") << summary.dump(2) << "\n";
}

void printSummary(const RunOptions& options, const system::SlamSystem& slam, const RunTally& tally,
                  double startup_ms, double peak_mib) {
  std::cout << "frames " << tally.frames << ", tracked " << tally.trajectory.size() << ", rejected "
            << tally.rejected << "; states:";
  for (const auto& [state, count] : tally.states)
    std::cout << " " << state << " " << count;
  std::cout << "\nloops closed: " << loopsJson(slam).size()
            << ", relocalisations: " << slam.relocalisations()
            << ", young maps discarded: " << slam.mapRestarts();
  std::cout << "\nmap: " << slam.map().numKeyframes() << " keyframes, " << slam.map().numPoints()
            << " points, " << slam.map().numObservations() << " observations\n"
            << tally.timings.table() << "start-up " << startup_ms << " ms, peak memory " << peak_mib
            << " MiB\noutputs in " << options.out.string() << "\n";
}

/// --load-map: the saved map, checked against this run's camera, becomes the SLAM's.
void loadMap(const RunOptions& options, const geometry::CameraCalibration& calibration,
             system::SlamSystem& slam) {
  io::MapFile file = io::loadMapFile(options.load_map);
  io::checkMapCamera(file, calibration, options.load_map);
  const map::Map& map = file.snapshot.map;
  std::cout << "map: " << map.numKeyframes() << " keyframes, " << map.numPoints() << " points, "
            << file.snapshot.loop_edges.size() << " loop edges from " << options.load_map
            << (options.localization ? " (localisation only)" : "") << "\n";
  if (file.params_yaml != io::formatSlamParams(options.params)) {
    std::cout << "map: made with other SLAM parameters than this run's (kept in the file)\n";
  }
  slam.restore(std::move(file.snapshot), options.localization);
}

/// --save-map: the map as the run leaves it.
void saveMap(const RunOptions& options, const geometry::CameraCalibration& calibration,
             const system::SlamSystem& slam) {
  io::MapFile file;
  file.calibration = calibration;
  file.params_yaml = io::formatSlamParams(options.params);
  file.map_version = slam.map().version();
  file.snapshot = slam.snapshot();
  io::saveMapFile(options.save_map, file);
  std::cout << "map saved to " << options.save_map << ": " << slam.map().numKeyframes()
            << " keyframes, " << slam.map().numPoints() << " points, "
            << fs::file_size(options.save_map) << " bytes\n";
}

int run(const io::CommandLine& args) {
  const common::Stopwatch timer;
  const RunOptions options = parseOptions(args);
  std::unique_ptr<io::ImageSequence> sequence = openDataset(args, options.dataset);
  const geometry::CameraCalibration calibration = calibrationOf(args, options.dataset, *sequence);
  fs::create_directories(options.out);
  cv::setNumThreads(1);  // one core for tracking; the mapping thread is the second
  if (!options.quiet) std::cout << "# parameters\n" << io::formatSlamParams(options.params);
  std::cout << "dataset: " << options.dataset << " (" << sequence->describe() << ")\n"
            << "camera: " << calibration.describe() << "\n";
  system::SlamSystem slam(geometry::makeCameraModel(calibration), options.params);
  if (!options.load_map.empty()) loadMap(options, calibration, slam);
  const double startup_ms = timer.ms();

  const RunTally tally = trackSequence(options, *sequence, slam);
  writeTrajectories(options, slam, tally);
  const double peak_mib = io::peakMemoryMiB();
  writeSummaryJson(options, slam, tally, startup_ms, peak_mib);
  printSummary(options, slam, tally, startup_ms, peak_mib);
  if (!options.save_map.empty()) {
    if (slam.map().numKeyframes() == 0) {
      std::cerr << "run_sequence: no map to save to " << options.save_map << "\n";
      return 1;
    }
    saveMap(options, calibration, slam);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return io::runTool(argc, argv, kUsage, {"quiet", "se3", "no-loop-closure", "localization"}, run);
}
