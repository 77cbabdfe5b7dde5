// run_sequence: the whole SLAM offline, in one process (tracking on this thread, the window BA and
// the loop closure on their own threads), on a TUM, EuRoC or KITTI folder or a rosbag. Writes
// DIR/trajectory.txt (every frame tracked in the final map, corrected by the loop closures, TUM,
// T_world_cam), DIR/trajectory_as_tracked.txt (the poses as they were output live), per young map
// discarded after a loss DIR/trajectory_map<K>_discarded.txt and
// DIR/trajectory_as_tracked_map<K>_discarded.txt (its own frame, never mixed with the final
// map's), DIR/keyframes.txt (the mapper's final keyframes, TUM), DIR/keyframes_before_loop_N.txt
// (the keyframes just before the N-th loop correction), DIR/frames.csv (each frame's tracking
// state, map, counts and message) and DIR/summary.json (counts, maps, loops, per-stage timing,
// memory). Exits non-zero with the reason when no frame was tracked.

#include <malloc.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <optional>
#include <string>
#include <thread>
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
                       before the N-th loop correction, TUM); the poses of each young map
                       discarded after a loss in trajectory[_as_tracked]_map<K>_discarded.txt
  --calib FILE         calibration YAML (default: the dataset's own, or the bag's CameraInfo)
  --config FILE        SLAM parameters (default: built-in defaults = config/default.yaml)
  --topic NAME         bag image topic (default /camera/image_raw)
  --camera-info-topic NAME   bag CameraInfo topic (default /camera/camera_info)
  --max-frames N       stop after N frames (default: all)
  --rate R             feed the frames at R times the rate of their stamps, as a live camera
                       or `rosbag play -r R` would (1: real time; the mapping and loop-closure
                       threads then get the time they have live); default 0: as fast as
                       tracking goes, so that they may fall behind on a slow machine
  --bit-depth N        16-bit images hold N-bit data (8..16; default: from their values)
  --se3                correct loops with the SE(3) pose graph (the paper's baseline)
  --no-loop-closure    no loop closure (relocalisation still works)
  --save-map FILE      save the map at the end (doc/map_file.md)
  --load-map FILE      start in a saved map: relocalise in it by place recognition, write the
                       trajectory in its frame, and extend it (new keyframes, loops)
  --localization       with --load-map: localise only, add no keyframe, leave the map as it is
  --quiet              no progress bar, no parameter dump
Exits with 1 and the reason when no frame was tracked (every frame rejected, or the map never
initialised); the outputs are written all the same.
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
    r.message = std::string("frame rejected: ") + (!frame.problem.empty() ? frame.problem
                                                   : frame.image.empty()  ? "unreadable"
                                                                          : e.what());
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
  if (r.times.keyframe_worker_cpu > 0.0) {
    timings->add("keyframe_worker_cpu", r.times.keyframe_worker_cpu);
  }
}

std::vector<io::StampedPose> posesOf(const map::CorrectedTrajectory& trajectory) {
  std::vector<io::StampedPose> poses;
  for (const map::CorrectedTrajectory::Frame& frame : trajectory.frames())
    poses.push_back({frame.timestamp, frame.T_cam_world.inverse()});
  return poses;
}

void addBackgroundTimes(const system::SlamSystem& slam, io::StageTimings* timings) {
  const system::BackgroundTimes times = slam.backgroundTimes();
  for (const double ms : times.window_ba_ms)
    timings->add("window_ba", ms);
  for (const double ms : times.place_recognition_ms)
    timings->add("place_recognition", ms);
  for (const double ms : times.place_query_ms)
    timings->add("place_query", ms);
  for (const double ms : times.verification_ms)
    timings->add("loop_verification", ms);
  for (const double ms : times.relocalisation_ms)
    timings->add("relocalisation", ms);
  for (const mapping::LoopCorrectionStatistics& loop : slam.loops()) {
    if (loop.applied) timings->add("loop_correction", loop.total_ms);
  }
}

/// The background work per keyframe, in the order the keyframes came (to see costs that grow).
nlohmann::json perKeyframeJson(const system::SlamSystem& slam) {
  const system::BackgroundTimes times = slam.backgroundTimes();
  return {{"window_ba", times.window_ba_ms},
          {"place_recognition", times.place_recognition_ms},
          {"place_query", times.place_query_ms},
          {"place_query_cpu", times.place_query_cpu_ms}};
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
    std::vector<double> S_current_loop(geometry::Sim3::kNumParameters);
    c.S_current_loop.toData(S_current_loop.data());
    loops.push_back({{"keyframes_before", loopSnapshotName(static_cast<int>(loops.size()))},
                     {"current_keyframe", c.current_id},
                     {"loop_keyframe", c.loop_id},
                     {"current_stamp", slam.map().keyframe(c.current_id).timestamp},
                     {"loop_stamp", slam.map().keyframe(c.loop_id).timestamp},
                     {"inliers", c.num_inliers},
                     {"matches", c.num_matches},
                     {"scale", c.scale},
                     {"S_current_loop", S_current_loop},  // qx qy qz qw tx ty tz log-scale
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
                     {"structure_only_ba_points", loop.structure_points},
                     {"map_points", loop.map_points},
                     {"correction_ms", loop.total_ms},
                     {"correction_cpu_ms", loop.total_cpu_ms},
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
  file << "frame,timestamp,state,map,rejected,visible,found,inliers,keyframes,new_points,"
          "candidates,relocalised,tracking_cpu_ms,keyframe_worker_cpu_ms,frame_ms,frame_cpu_ms,"
          "inbox_ms,inbox_cpu_ms,"
          "mapper_backlog,rss_mib,"
          "message\n";
  return file;
}

/// The load of one frame: its call's wall and CPU time, the part spent applying map updates, the
/// keyframes waiting for the mapper after it and the process's resident memory.
struct FrameLoad {
  double frame_ms = 0.0, frame_cpu_ms = 0.0;  ///< Wall and tracking-thread CPU time.
  double inbox_ms = 0.0, inbox_cpu_ms = 0.0;
  std::size_t mapper_backlog = 0;
  double rss_mib = 0.0;
};

/// `candidates`: feature candidates alive after the frame (tracking::Tracker::numCandidates).
/// `map`: the map the frame belongs to (0, then one more at each young map discarded).
void logFrame(int index, const io::SequenceFrame& frame, const tracking::FrameResult& r, int map,
              std::size_t candidates, const FrameLoad& load, std::ofstream* file) {
  std::string message = r.message;
  std::replace(message.begin(), message.end(), '"', '\'');
  std::size_t new_points = 0;
  for (const map::KeyframeMessage& keyframe : r.keyframes)
    new_points += keyframe.new_points.size();
  *file << index << ',' << std::fixed << std::setprecision(6) << frame.timestamp << ','
        << trackingStateName(r.state) << ',' << map << ',' << r.rejected << ',' << r.num_visible
        << ',' << r.num_found << ',' << r.num_inliers << ',' << r.keyframes.size() << ','
        << new_points << ',' << candidates << ',' << r.relocalised << ',' << std::setprecision(3)
        << r.times.cpu << ',' << r.times.keyframe_worker_cpu << ',' << load.frame_ms << ','
        << load.frame_cpu_ms << ',' << load.inbox_ms << ',' << load.inbox_cpu_ms << ','
        << load.mapper_backlog << ',' << std::setprecision(1) << load.rss_mib << ",\"" << message
        << "\"\n";
}

/// What run_sequence was asked to do.
struct RunOptions {
  std::string dataset;
  fs::path out;
  long max_frames = -1;  // -1: all
  double rate = 0.0;     // 0: as fast as possible
  bool quiet = false;
  system::SlamParams params;
  std::string save_map, load_map;
  bool localization = false;
};

RunOptions parseOptions(const io::CommandLine& args) {
  args.rejectUnknownFlags({"out", "calib", "config", "topic", "camera-info-topic", "max-frames",
                           "rate", "quiet", "se3", "no-loop-closure", "save-map", "load-map",
                           "localization", "bit-depth"});
  RunOptions options;
  options.dataset = args.positional(0, "DATASET");
  options.out = args.required("out");
  options.max_frames = args.integer("max-frames", -1);
  options.rate = args.number("rate", 0.0);
  if (!(options.rate >= 0.0) || !std::isfinite(options.rate)) {
    throw std::invalid_argument("--rate must be a number >= 0 (0: as fast as possible)");
  }
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
  if (args.has("bit-depth")) {
    params.tracker.mono16_bit_depth = static_cast<int>(args.integer("bit-depth", 0));
    params.validate();
  }
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
  std::vector<std::vector<io::StampedPose>> as_tracked;  // as output live, per map (0, 1, ..)
  std::size_t tracked = 0;                               // poses in all maps
  io::StageTimings timings;
  std::map<std::string, int> states;
  std::map<std::string, int> rejections;  // by reason (the message up to its figures)
  int frames = 0;
  int rejected = 0;
};

/// Feeds the frames to the SLAM, logging each to frames.csv; finishes the background threads.
/// --rate: holds each frame back until its stamp, relative to the first frame's, has passed on
/// the wall clock (scaled by the rate). Stamps going back (a bag's) are not waited for.
class FramePacer {
 public:
  explicit FramePacer(double rate) : rate_(rate) {}
  void waitFor(double stamp) {
    if (!(rate_ > 0.0)) return;
    const auto now = std::chrono::steady_clock::now();
    if (!started_) {
      started_ = true;
      first_stamp_ = stamp;
      start_ = now;
      return;
    }
    const auto due = start_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                  std::chrono::duration<double>((stamp - first_stamp_) / rate_));
    if (due > now) std::this_thread::sleep_until(due);
  }

 private:
  double rate_;
  bool started_ = false;
  double first_stamp_ = 0.0;
  std::chrono::steady_clock::time_point start_;
};

RunTally trackSequence(const RunOptions& options, io::ImageSequence& sequence,
                       system::SlamSystem& slam) {
  RunTally tally;
  std::ofstream frame_log = openFrameLog(options.out / "frames.csv");
  const long max_frames = options.max_frames;
  const std::size_t total =
      max_frames >= 0 ? std::min<std::size_t>(max_frames, sequence.size()) : sequence.size();
  const bool progress = !options.quiet && isatty(STDERR_FILENO);
  FramePacer pacer(options.rate);
  while (max_frames < 0 || tally.frames < max_frames) {
    const std::optional<io::SequenceFrame> frame = sequence.next();
    if (!frame) break;
    pacer.waitFor(frame->timestamp);
    ++tally.frames;
    const common::Stopwatch frame_timer;
    const double frame_cpu_start = common::threadCpuMs();
    const tracking::FrameResult r = processOne(slam, *frame);
    const double frame_cpu_ms = common::threadCpuMs() - frame_cpu_start;
    // What the camera sees: the whole call, with map updates applied (and the window BA when
    // the mapper runs inline).
    const double frame_ms = frame_timer.ms();
    if (r.rejected) {
      ++tally.rejected;
      ++tally.rejections[r.message.substr(0, r.message.find(" ("))];
      std::cerr << (progress ? "\n" : "") << frame->source << ": " << r.message << "\n";
    } else {
      ++tally.states[trackingStateName(r.state)];
      addTimes(r, &tally.timings);
      if (r.state != tracking::TrackingState::kInitializing) tally.timings.add("frame", frame_ms);
    }
    const int map = slam.mapRestarts();
    if (r.has_pose) {
      tally.as_tracked.resize(std::max<std::size_t>(tally.as_tracked.size(), map + 1));
      tally.as_tracked[map].push_back({frame->timestamp, r.T_cam_world.inverse()});
      ++tally.tracked;
    }
    const FrameLoad load{frame_ms,
                         frame_cpu_ms,
                         slam.lastInboxMs(),
                         slam.lastInboxCpuMs(),
                         slam.mapperBacklog(),
                         io::residentMemoryMiB()};
    logFrame(tally.frames - 1, *frame, r, map, slam.tracker().numCandidates(), load, &frame_log);
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

/// Writes one trajectory file, sorted by stamp with repeated stamps dropped (a bag's stamps can
/// go back or repeat); says so in `notes`.
void writePoses(const fs::path& path, std::vector<io::StampedPose> poses,
                const std::string& comment, std::vector<std::string>* notes) {
  std::size_t reordered = 0;
  const std::size_t dropped = io::sortAndDropRepeatedStamps(&poses, &reordered);
  if (reordered > 0 || dropped > 0) {
    notes->push_back(path.filename().string() + ": " + std::to_string(reordered) +
                     " pose(s) out of stamp order sorted, " + std::to_string(dropped) +
                     " pose(s) repeating a stamp dropped");
  }
  io::saveTumTrajectory(path.string(), poses, comment);
}

/// What the outputs hold: the files written and what had to be fixed in them.
struct OutputReport {
  nlohmann::json maps = nlohmann::json::array();
  std::vector<std::string> notes;
};

/// trajectory.txt, trajectory_as_tracked.txt (the final map), the same per discarded map, and
/// keyframes.txt.
OutputReport writeTrajectories(const RunOptions& options, const system::SlamSystem& slam,
                               RunTally tally) {
  const fs::path& out = options.out;
  const int final_map = slam.mapRestarts();
  tally.as_tracked.resize(final_map + 1);
  OutputReport report;
  for (int k = 0; k <= final_map; ++k) {
    const bool discarded = k < final_map;
    const std::string suffix = discarded ? "_map" + std::to_string(k) + "_discarded" : "";
    const std::string which =
        discarded ? "map " + std::to_string(k) + " (discarded after a loss; its own frame)"
                  : "map " + std::to_string(k) + " (the final map)";
    const map::CorrectedTrajectory& corrected =
        discarded ? slam.discardedTrajectories()[k] : slam.trajectory();
    writePoses(out / ("trajectory" + suffix + ".txt"), posesOf(corrected),
               "every frame tracked in " + which + ", corrected by the loop closures, " +
                   "T_world_cam, run_sequence " + options.dataset,
               &report.notes);
    writePoses(out / ("trajectory_as_tracked" + suffix + ".txt"), tally.as_tracked[k],
               "every frame tracked in " + which + " as output live, T_world_cam, run_sequence " +
                   options.dataset,
               &report.notes);
    report.maps.push_back({{"map", k},
                           {"discarded", discarded},
                           {"tracked", tally.as_tracked[k].size()},
                           {"trajectory", "trajectory" + suffix + ".txt"},
                           {"trajectory_as_tracked", "trajectory_as_tracked" + suffix + ".txt"}});
  }
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
  return report;
}

/// Why nothing was tracked, from what the frames were told; "" when something was.
std::string nothingTrackedReason(const RunTally& tally) {
  if (tally.tracked > 0) return "";
  if (tally.frames == 0) return "the dataset gave no frame";
  std::string reasons;
  for (const auto& [reason, count] : tally.rejections)
    reasons += (reasons.empty() ? "" : "; ") + reason + " (" + std::to_string(count) + "x)";
  if (tally.rejected == tally.frames) {
    return "tracked nothing: all " + std::to_string(tally.frames) +
           " frames were rejected: " + reasons;
  }
  return "tracked nothing: the map never initialised in " + std::to_string(tally.frames) +
         " frames (" + std::to_string(tally.rejected) + " rejected" +
         (reasons.empty() ? "" : ": " + reasons) +
         "); check the calibration and that the camera moves sideways at the start";
}

/// Keyframes culled as redundant (mapping/keyframe_culling.h): they hold no observations.
std::size_t culledKeyframes(const map::Map& map) {
  std::size_t culled = 0;
  for (const auto& [id, keyframe] : map.keyframes())
    culled += keyframe.observations.empty();
  return culled;
}

void writeSummaryJson(const RunOptions& options, const system::SlamSystem& slam,
                      const RunTally& tally, const OutputReport& outputs,
                      const std::vector<std::string>& dataset_warnings, double startup_ms,
                      double peak_mib) {
  const std::string& dataset = options.dataset;
  const nlohmann::json summary = {
      {"dataset", dataset},
      {"rate", options.rate},
      {"frames", tally.frames},
      {"rejected_frames", tally.rejected},
      {"tracked", tally.tracked},
      {"tracked_final_map", outputs.maps.back()["tracked"]},
      {"maps", outputs.maps},
      {"rejections", tally.rejections},
      {"dataset_warnings", dataset_warnings},
      {"output_warnings", outputs.notes},
      {"nothing_tracked", nothingTrackedReason(tally)},
      {"states", tally.states},
      {"keyframes", slam.map().numKeyframes()},
      {"keyframes_culled", culledKeyframes(slam.map())},
      {"points", slam.map().numPoints()},
      {"observations", slam.map().numObservations()},
      {"loops", loopsJson(slam)},
      {"relocalisations", slam.relocalisations()},
      {"map_restarts", slam.mapRestarts()},
      {"loaded_map_keyframes", slam.restoredKeyframes()},
      {"keyframes_added", slam.map().numKeyframes() - slam.restoredKeyframes()},
      {"timing", tally.timings.toJson()},
      {"per_keyframe_ms", perKeyframeJson(slam)},
      {"startup_ms", startup_ms},
      {"peak_memory_mib", peak_mib}};
  std::ofstream(options.out / "summary.json") << summary.dump(2) << "\n";
}

void printSummary(const RunOptions& options, const system::SlamSystem& slam, const RunTally& tally,
                  double startup_ms, double peak_mib) {
  std::cout << "frames " << tally.frames << ", tracked " << tally.tracked << ", rejected "
            << tally.rejected << "; states:";
  for (const auto& [state, count] : tally.states)
    std::cout << " " << state << " " << count;
  std::cout << "\nloops closed: " << loopsJson(slam).size()
            << ", relocalisations: " << slam.relocalisations()
            << ", young maps discarded: " << slam.mapRestarts();
  for (int k = 0; k < slam.mapRestarts(); ++k) {
    std::cout << (k ? ", " : " (their poses: ") << "trajectory[_as_tracked]_map" << k
              << "_discarded.txt" << (k + 1 == slam.mapRestarts() ? ")" : "");
  }
  std::cout << "\nmap: " << slam.map().numKeyframes() << " keyframes ("
            << culledKeyframes(slam.map()) << " culled), " << slam.map().numPoints() << " points, "
            << slam.map().numObservations() << " observations\n"
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
  // The tracking, mapping and loop-closure threads hand keyframes to each other; glibc gives each
  // thread a malloc arena of its own, whose free pages the others do not reuse. Two arenas keep
  // city_tour (1311 keyframes, real time) 8 MiB lower (doc/benchmarks.md "Memory at city scale").
  mallopt(M_ARENA_MAX, 2);
  if (!options.quiet) std::cout << "# parameters\n" << io::formatSlamParams(options.params);
  std::cout << "dataset: " << options.dataset << " (" << sequence->describe() << ")\n"
            << "camera: " << calibration.describe() << "\n";
  const std::vector<std::string> dataset_warnings = sequence->warnings();
  for (const std::string& warning : dataset_warnings)
    std::cerr << "warning: " << warning << "\n";
  system::SlamSystem slam(geometry::makeCameraModel(calibration), options.params);
  if (!options.load_map.empty()) loadMap(options, calibration, slam);
  const double startup_ms = timer.ms();

  const RunTally tally = trackSequence(options, *sequence, slam);
  const std::vector<std::string> all_warnings = sequence->warnings();  // a bag may add some
  for (std::size_t i = dataset_warnings.size(); i < all_warnings.size(); ++i)
    std::cerr << "warning: " << all_warnings[i] << "\n";
  const OutputReport outputs = writeTrajectories(options, slam, tally);
  for (const std::string& note : outputs.notes)
    std::cerr << "warning: " << note << "\n";
  const double peak_mib = io::peakMemoryMiB();
  writeSummaryJson(options, slam, tally, outputs, all_warnings, startup_ms, peak_mib);
  printSummary(options, slam, tally, startup_ms, peak_mib);
  const std::string nothing = nothingTrackedReason(tally);
  if (!nothing.empty()) throw std::runtime_error(nothing);
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
