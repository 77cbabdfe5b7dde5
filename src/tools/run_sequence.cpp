// run_sequence: the whole SLAM offline, in one process (tracking on this thread, the window BA on
// the mapping thread), on a TUM, EuRoC or KITTI folder or a rosbag. Writes DIR/trajectory.txt
// (every tracked frame, TUM, T_world_cam), DIR/keyframes.txt (the mapper's keyframes after the
// last window BA, TUM) and DIR/summary.json (counts, per-stage timing, memory).

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>

#include <opencv2/core.hpp>

#include "scale_drift_slam/io/calibration_io.h"
#include "scale_drift_slam/io/command_line.h"
#include "scale_drift_slam/io/image_sequence.h"
#include "scale_drift_slam/io/run_statistics.h"
#include "scale_drift_slam/io/slam_params_io.h"
#include "scale_drift_slam/io/trajectory_io.h"
#include "scale_drift_slam/mapping/slam_system.h"
#include "scale_drift_slam/ros/bag_image_sequence.h"

namespace {

using namespace scale_drift_slam;
namespace fs = std::filesystem;

const char* const kUsage =
    R"(usage: run_sequence DATASET --out DIR [--calib FILE] [--config FILE] [options]

Runs the monocular SLAM offline on DATASET: a TUM folder (rgb.txt [+ camera.yaml]), an EuRoC
folder (mav0/cam0/data.csv + sensor.yaml), a KITTI odometry folder (image_0/, times.txt,
calib.txt) or a rosbag (*.bag).
  --out DIR            output folder: trajectory.txt, keyframes.txt (TUM), summary.json
  --calib FILE         calibration YAML (default: the dataset's own, or the bag's CameraInfo)
  --config FILE        SLAM parameters (default: built-in defaults = config/default.yaml)
  --topic NAME         bag image topic (default /camera/image_raw)
  --camera-info-topic NAME   bag CameraInfo topic (default /camera/camera_info)
  --max-frames N       stop after N frames (default: all)
  --quiet              no progress bar, no parameter dump
)";

std::unique_ptr<io::ImageSequence> openDataset(const io::CommandLine& args,
                                               const std::string& dataset) {
  if (fs::path(dataset).extension() == ".bag") {
    return ros_bag::openBagImageSequence(dataset, args.text("topic", "/camera/image_raw"),
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

tracking::FrameResult processOne(mapping::SlamSystem& slam, const io::SequenceFrame& frame) {
  try {
    const tracking::PixelEncoding encoding = frame.encoding.empty()
                                                 ? tracking::encodingOfMat(frame.image)
                                                 : tracking::parsePixelEncoding(frame.encoding);
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

int run(const io::CommandLine& args) {
  const auto start = std::chrono::steady_clock::now();
  args.rejectUnknownFlags(
      {"out", "calib", "config", "topic", "camera-info-topic", "max-frames", "quiet"});
  const std::string dataset = args.positional(0, "DATASET");
  const fs::path out = args.required("out");
  const long max_frames = args.integer("max-frames", -1);
  const bool quiet = args.has("quiet");
  const mapping::SlamParams params =
      args.has("config") ? io::loadSlamParams(args.required("config")) : mapping::SlamParams{};
  std::unique_ptr<io::ImageSequence> sequence = openDataset(args, dataset);
  geometry::CameraCalibration calibration;
  if (args.has("calib")) {
    calibration = io::loadCalibrationYaml(args.required("calib"));
  } else if (sequence->calibration()) {
    calibration = *sequence->calibration();
  } else {
    throw std::invalid_argument("'" + dataset + "' has no calibration of its own: pass --calib");
  }
  fs::create_directories(out);
  cv::setNumThreads(1);  // one core for tracking; the mapping thread is the second
  if (!quiet) std::cout << "# parameters\n" << io::formatSlamParams(params);
  std::cout << "dataset: " << dataset << " (" << sequence->describe() << ")\n"
            << "camera: " << calibration.describe() << "\n";
  mapping::SlamSystem slam(geometry::makeCameraModel(calibration), params);
  const double startup_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();

  std::vector<io::StampedPose> trajectory;
  io::StageTimings timings;
  std::map<std::string, int> states;
  int frames = 0, rejected = 0;
  const std::size_t total =
      max_frames >= 0 ? std::min<std::size_t>(max_frames, sequence->size()) : sequence->size();
  const bool progress = !quiet && isatty(STDERR_FILENO);
  while (max_frames < 0 || frames < max_frames) {
    const std::optional<io::SequenceFrame> frame = sequence->next();
    if (!frame) break;
    ++frames;
    const auto frame_start = std::chrono::steady_clock::now();
    const tracking::FrameResult r = processOne(slam, *frame);
    // What the camera sees: the whole call, with map updates applied (and the window BA when
    // the mapper runs inline).
    const double frame_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - frame_start)
            .count();
    if (r.rejected) {
      ++rejected;
      std::cerr << (progress ? "\n" : "") << frame->source << ": " << r.message << "\n";
    } else {
      ++states[trackingStateName(r.state)];
      addTimes(r, &timings);
      if (r.state != tracking::TrackingState::kInitializing) timings.add("frame", frame_ms);
    }
    if (r.has_pose) trajectory.push_back({frame->timestamp, r.T_cam_world.inverse()});
    if (progress && (frames % 10 == 0 || frames == static_cast<int>(total))) {
      printProgress(frames, total, r);
    }
  }
  if (progress) std::fprintf(stderr, "\n");
  slam.finish();
  for (const double ms : slam.windowBaTimesMs())
    timings.add("window_ba", ms);

  io::saveTumTrajectory((out / "trajectory.txt").string(), trajectory,
                        "every tracked frame, T_world_cam, run_sequence " + dataset);
  io::saveTumTrajectory((out / "keyframes.txt").string(), keyframePoses(slam.map()),
                        "keyframes after the last window BA, T_world_cam");
  const double peak_mib = io::peakMemoryMiB();
  const nlohmann::json summary = {{"dataset", dataset},
                                  {"frames", frames},
                                  {"rejected_frames", rejected},
                                  {"tracked", trajectory.size()},
                                  {"states", states},
                                  {"keyframes", slam.map().numKeyframes()},
                                  {"points", slam.map().numPoints()},
                                  {"observations", slam.map().numObservations()},
                                  {"loops", nlohmann::json::array()},
                                  {"timing", timings.toJson()},
                                  {"startup_ms", startup_ms},
                                  {"peak_memory_mib", peak_mib}};
  std::ofstream(out / "summary.json") << summary.dump(2) << "\n";
  std::cout << "frames " << frames << ", tracked " << trajectory.size() << ", rejected " << rejected
            << "; states:";
  for (const auto& [state, count] : states)
    std::cout << " " << state << " " << count;
  std::cout << "\nmap: " << slam.map().numKeyframes() << " keyframes, " << slam.map().numPoints()
            << " points, " << slam.map().numObservations() << " observations\n"
            << timings.table() << "start-up " << startup_ms << " ms, peak memory " << peak_mib
            << " MiB\noutputs in " << out.string() << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return io::runTool(argc, argv, kUsage, {"quiet"}, run);
}
