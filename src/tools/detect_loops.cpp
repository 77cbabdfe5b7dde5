// detect_loops: place recognition alone on an image folder (doc/place_recognition.md). Picks
// keyframes (every N-th frame, or by ground-truth motion), runs loop::PlaceRecognizer on them in
// order and reports the accepted loops, checked against the ground truth when the folder has one.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "scale_drift_slam/common/stopwatch.h"
#include "scale_drift_slam/io/calibration_io.h"
#include "scale_drift_slam/io/command_line.h"
#include "scale_drift_slam/io/place_recognition_params_io.h"
#include "scale_drift_slam/io/trajectory_io.h"
#include "scale_drift_slam/loop/place_recognizer.h"

namespace sds = scale_drift_slam;

namespace {

const char* kUsage =
    "usage: detect_loops DATASET --out DIR [options]\n"
    "Runs place recognition (loop detection by appearance) on the keyframes of a TUM-layout\n"
    "folder (DATASET/rgb.txt, optional DATASET/groundtruth.txt) and writes\n"
    "DIR/loops.json (accepted loops; with ground truth: camera distance, view angle, true/false)\n"
    "and DIR/queries.txt (per keyframe query: the loop or why there is none, and every\n"
    "candidate checked with its geometric figures).\n"
    "Options:\n"
    "  --config FILE            place recognition params (default: config/place_recognition.yaml\n"
    "                           defaults, compiled in)\n"
    "  --vocabulary FILE        a vocabulary file (default: learned online from the keyframes)\n"
    "  --calib FILE             camera calibration; keypoints are undistorted with it (default:\n"
    "                           DATASET/camera.yaml when present, else raw pixels)\n"
    "  --every N                every N-th frame is a keyframe (default 10)\n"
    "  --keyframe-distance M    instead: a keyframe when the true camera moved M (needs ground\n"
    "                           truth), or turned by --keyframe-angle degrees (default 10)\n"
    "  --true-distance M        a loop is true when the cameras are within M (default 3.0) ...\n"
    "  --true-angle DEG         ... and their optical axes within DEG degrees (default 30)\n";

struct Frame {
  double timestamp = 0.0;
  std::string path;
};

/// DATASET/rgb.txt: "timestamp path" lines, '#' comments (the TUM RGB-D layout).
std::vector<Frame> readFrameList(const std::string& folder) {
  const std::string list = folder + "/rgb.txt";
  std::ifstream file(list);
  if (!file) throw std::runtime_error("cannot open " + list);
  std::vector<Frame> frames;
  std::string line;
  for (int number = 1; std::getline(file, line); ++number) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    Frame frame;
    if (!(fields >> frame.timestamp >> frame.path)) {
      throw std::runtime_error(list + ":" + std::to_string(number) + ": expected 'timestamp path'");
    }
    frame.path = folder + "/" + frame.path;
    frames.push_back(frame);
  }
  if (frames.empty()) throw std::runtime_error(list + " lists no image");
  return frames;
}

/// The ground-truth pose closest in time (within 20 ms), if any.
const sds::io::StampedPose* poseAt(const std::vector<sds::io::StampedPose>& truth, double t) {
  const auto it = std::lower_bound(
      truth.begin(), truth.end(), t,
      [](const sds::io::StampedPose& pose, double time) { return pose.timestamp < time; });
  const sds::io::StampedPose* best = nullptr;
  for (auto candidate : {it, it == truth.begin() ? it : it - 1}) {
    if (candidate == truth.end()) continue;
    if (std::abs(candidate->timestamp - t) > 0.02) continue;
    if (best == nullptr || std::abs(candidate->timestamp - t) < std::abs(best->timestamp - t)) {
      best = &*candidate;
    }
  }
  return best;
}

double angleDeg(const sds::geometry::SE3& a, const sds::geometry::SE3& b) {
  const Eigen::Vector3d za = a.rotationMatrix().col(2);
  const Eigen::Vector3d zb = b.rotationMatrix().col(2);
  return std::acos(std::clamp(za.dot(zb), -1.0, 1.0)) * 180.0 / M_PI;
}

/// Frame indices that become keyframes.
std::vector<std::size_t> pickKeyframes(const std::vector<Frame>& frames,
                                       const std::vector<sds::io::StampedPose>& truth,
                                       const sds::io::CommandLine& cl) {
  std::vector<std::size_t> keyframes;
  if (!cl.has("keyframe-distance")) {
    const long every = cl.integer("every", 10);
    if (every < 1) throw std::invalid_argument("--every must be >= 1");
    for (std::size_t i = 0; i < frames.size(); i += static_cast<std::size_t>(every)) {
      keyframes.push_back(i);
    }
    return keyframes;
  }
  const double distance = cl.number("keyframe-distance", 0.0);
  const double angle = cl.number("keyframe-angle", 10.0);
  if (!(distance > 0.0) || !(angle > 0.0)) {
    throw std::invalid_argument("--keyframe-distance and --keyframe-angle must be > 0");
  }
  if (truth.empty()) throw std::invalid_argument("--keyframe-distance needs groundtruth.txt");
  const sds::io::StampedPose* last = nullptr;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const sds::io::StampedPose* pose = poseAt(truth, frames[i].timestamp);
    if (pose == nullptr) continue;
    if (last == nullptr ||
        (pose->T_world_cam.translation() - last->T_world_cam.translation()).norm() > distance ||
        angleDeg(pose->T_world_cam, last->T_world_cam) > angle) {
      keyframes.push_back(i);
      last = pose;
    }
  }
  return keyframes;
}

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  return values[static_cast<std::size_t>(p * (values.size() - 1))];
}

/// DATASET/groundtruth.txt sorted by time; empty when there is none.
std::vector<sds::io::StampedPose> loadTruth(const std::string& dataset) {
  std::vector<sds::io::StampedPose> truth;
  if (std::ifstream(dataset + "/groundtruth.txt")) {
    truth = sds::io::loadTrajectory(dataset + "/groundtruth.txt");
    std::sort(truth.begin(), truth.end(),
              [](const auto& a, const auto& b) { return a.timestamp < b.timestamp; });
  }
  return truth;
}

/// --calib, else DATASET/camera.yaml when present; null: keypoints stay in raw pixels.
std::unique_ptr<sds::geometry::CameraModel> openCamera(const sds::io::CommandLine& cl,
                                                       const std::string& dataset) {
  const std::string calib = cl.text("calib", dataset + "/camera.yaml");
  if (cl.has("calib") || std::ifstream(calib)) {
    return sds::geometry::makeCameraModel(sds::io::loadCalibrationYaml(calib));
  }
  return nullptr;
}

/// queries.txt: the query's outcome and every candidate checked with its geometric figures.
void logQuery(const sds::loop::PlaceQueryResult& result, std::ofstream& queries) {
  queries << result.describe() << "\n";
  for (const sds::loop::LoopCandidate& c : result.candidates) {
    char line[256];
    std::snprintf(line, sizeof(line),
                  "  candidate %u: normalised %.2f, %d matches, %d inliers (%s), coverage %.2f, "
                  "scale change %.2f, %d consecutive: %s",
                  c.keyframe_id, c.normalized_score, c.geometry.matches, c.geometry.inliers,
                  c.geometry.model.empty() ? "-" : c.geometry.model.c_str(), c.geometry.coverage,
                  c.geometry.scale_change, c.consistent_queries, sds::loop::toString(c.status));
    queries << line << (c.reason.empty() ? "" : ": " + c.reason) << "\n";
  }
}

/// What the keyframe loop gathered.
struct DetectionTally {
  nlohmann::json loops = nlohmann::json::array();
  std::vector<double> extract_ms;
  std::vector<double> query_ms;
  int true_loops = 0;
  int false_loops = 0;
};

/// The accepted loop as loops.json lists it; with ground truth, whether it is true (cameras
/// within true_distance and true_angle), counted in the tally.
nlohmann::json loopEntry(const std::vector<Frame>& frames, std::size_t k,
                         const sds::loop::LoopCandidate& loop,
                         const std::vector<sds::io::StampedPose>& truth, double true_distance,
                         double true_angle, DetectionTally* tally) {
  nlohmann::json entry = {{"query_id", static_cast<sds::map::KeyframeId>(k)},
                          {"query_time", frames[k].timestamp},
                          {"match_id", loop.keyframe_id},
                          {"match_time", frames[loop.keyframe_id].timestamp},
                          {"score", loop.score},
                          {"normalized_score", loop.normalized_score},
                          {"matches", loop.geometry.matches},
                          {"inliers", loop.geometry.inliers},
                          {"coverage", loop.geometry.coverage},
                          {"scale_change", loop.geometry.scale_change},
                          {"model", loop.geometry.model},
                          {"consistent_queries", loop.consistent_queries}};
  const auto* a = truth.empty() ? nullptr : poseAt(truth, frames[k].timestamp);
  const auto* b = truth.empty() ? nullptr : poseAt(truth, frames[loop.keyframe_id].timestamp);
  if (a != nullptr && b != nullptr) {
    const double d = (a->T_world_cam.translation() - b->T_world_cam.translation()).norm();
    const double angle = angleDeg(a->T_world_cam, b->T_world_cam);
    const bool correct = d <= true_distance && angle <= true_angle;
    (correct ? tally->true_loops : tally->false_loops) += 1;
    entry["true_distance"] = d;
    entry["true_angle_deg"] = angle;
    entry["correct"] = correct;
  }
  return entry;
}

/// DIR/loops.json (the counts, timing medians and loops) and a one-line report.
void writeSummary(const std::string& dataset, const std::string& out, std::size_t num_frames,
                  std::size_t num_keyframes, const sds::loop::PlaceRecognizer& recognizer,
                  const std::vector<sds::io::StampedPose>& truth, bool undistorted,
                  const DetectionTally& tally) {
  const nlohmann::json summary = {
      {"dataset", dataset},
      {"frames", num_frames},
      {"keyframes", num_keyframes},
      {"vocabulary_words", recognizer.vocabularyReady() ? recognizer.vocabulary()->numWords() : 0},
      {"loops_accepted", tally.loops.size()},
      {"loops_true", tally.true_loops},
      {"loops_false", tally.false_loops},
      {"ground_truth", !truth.empty()},
      {"undistorted", undistorted},
      {"extract_ms_median", percentile(tally.extract_ms, 0.5)},
      {"query_ms_median", percentile(tally.query_ms, 0.5)},
      {"query_ms_p95", percentile(tally.query_ms, 0.95)},
      {"loops", tally.loops}};
  std::ofstream(out + "/loops.json") << summary.dump(2) << "\n";
  std::printf(
      "%zu keyframes of %zu frames: %zu loops accepted (%d true, %d false%s); query %.2f ms "
      "median, %.2f ms p95; extraction %.1f ms median\n",
      num_keyframes, num_frames, tally.loops.size(), tally.true_loops, tally.false_loops,
      truth.empty() ? ", no ground truth" : "", percentile(tally.query_ms, 0.5),
      percentile(tally.query_ms, 0.95), percentile(tally.extract_ms, 0.5));
}

int run(const sds::io::CommandLine& cl) {
  cl.rejectUnknownFlags({"out", "config", "vocabulary", "calib", "every", "keyframe-distance",
                         "keyframe-angle", "true-distance", "true-angle"});
  const std::string dataset = cl.positional(0, "DATASET");
  const std::string out = cl.required("out");
  sds::loop::PlaceRecognitionParams params;
  if (cl.has("config")) params = sds::io::loadPlaceRecognitionParams(cl.required("config"));
  if (cl.has("vocabulary")) params.vocabulary_file = cl.required("vocabulary");
  const double true_distance = cl.number("true-distance", 3.0);
  const double true_angle = cl.number("true-angle", 30.0);

  const std::vector<Frame> frames = readFrameList(dataset);
  const std::vector<sds::io::StampedPose> truth = loadTruth(dataset);
  const std::vector<std::size_t> keyframes = pickKeyframes(frames, truth, cl);
  std::filesystem::create_directories(out);

  const std::unique_ptr<sds::geometry::CameraModel> camera = openCamera(cl, dataset);
  sds::loop::PlaceRecognizer recognizer(params);
  sds::loop::AppearanceExtractor extractor(params.appearance);
  std::ofstream queries(out + "/queries.txt");
  DetectionTally tally;
  for (std::size_t k : keyframes) {
    const cv::Mat image = cv::imread(frames[k].path, cv::IMREAD_GRAYSCALE);
    if (image.empty()) throw std::runtime_error("cannot read image " + frames[k].path);
    sds::common::Stopwatch stage;
    sds::loop::KeyframeAppearance appearance = extractor.extract(image, camera.get());
    tally.extract_ms.push_back(stage.lapMs());
    const auto id = static_cast<sds::map::KeyframeId>(k);
    const sds::loop::PlaceQueryResult result =
        recognizer.query(id, frames[k].timestamp, appearance);
    tally.query_ms.push_back(stage.lapMs());
    recognizer.add(id, frames[k].timestamp, std::move(appearance));
    logQuery(result, queries);
    const sds::loop::LoopCandidate* loop = result.accepted();
    if (loop == nullptr) continue;
    tally.loops.push_back(loopEntry(frames, k, *loop, truth, true_distance, true_angle, &tally));
    std::cout << result.describe() << "\n";
  }
  writeSummary(dataset, out, frames.size(), keyframes.size(), recognizer, truth, camera != nullptr,
               tally);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return sds::io::runTool(argc, argv, kUsage, {}, run);
}
