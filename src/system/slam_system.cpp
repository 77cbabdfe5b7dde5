#include "scale_drift_slam/system/slam_system.h"

#include <utility>

#include "scale_drift_slam/common/stopwatch.h"

namespace scale_drift_slam::system {

namespace {

double focalOf(const std::shared_ptr<const geometry::CameraModel>& camera) {
  if (!camera) throw std::invalid_argument("the SLAM needs a camera model");
  return camera->calibration().meanFocalLength();
}

/// Inline, everything happens within the frame that causes it: no keyframe worker either.
tracking::TrackerParams trackerParams(const SlamParams& params) {
  tracking::TrackerParams tracker = params.tracker;
  if (!params.mapping_thread) tracker.keyframe_worker = false;
  return tracker;
}

}  // namespace

SlamSystem::SlamSystem(const std::shared_ptr<const geometry::CameraModel>& camera,
                       const SlamParams& params)
    : params_(params),
      camera_(camera),
      tracker_(camera, trackerParams(params)),
      mapper_(params.mapper, /*mapper_id=*/1, params.messages),
      loop_closer_(params.loop, params.messages) {
  focalOf(camera_);  // throws without a camera
  tracker_inbox_.startSession(session_);
  if (params_.mapping_thread) {
    mapping_thread_ = std::thread([this] {
      while (std::optional<MapperInput> input = mapper_inbox_.waitPop())
        handleSafely(std::move(*input));
    });
    loop_thread_ = std::thread([this] {
      while (std::optional<LoopInput> input = loop_inbox_.waitPop())
        handleSafely(std::move(*input));
    });
  }
}

SlamSystem::~SlamSystem() {
  finish();
}

void SlamSystem::finish() {
  if (finished_) return;
  sendKeyframes(tracker_.finishKeyframes());  // the last keyframe's worker may still be busy
  finished_ = true;
  if (params_.mapping_thread) {
    // The loop closer first: its last constraints still reach the open mapper queue.
    loop_inbox_.close();
    if (loop_thread_.joinable()) loop_thread_.join();
    mapper_inbox_.close();
    if (mapping_thread_.joinable()) mapping_thread_.join();
  } else {
    runInline();
  }
  drainInbox();
}

tracking::FrameResult SlamSystem::processFrame(double timestamp, const cv::Mat& image,
                                               features::PixelEncoding encoding) {
  started_ = true;
  const common::Stopwatch inbox_timer;
  const double inbox_cpu_start = common::threadCpuMs();
  drainInbox();
  last_inbox_cpu_ms_ = common::threadCpuMs() - inbox_cpu_start;
  last_inbox_ms_ = inbox_timer.ms();
  const int mono16_bits = tracker_.mono16BitDepth();
  tracking::FrameResult result = tracker_.processFrame(timestamp, image, encoding);
  if (tracker_.mono16BitDepth() != mono16_bits) log(tracker_.describeMono16BitDepth());
  if (result.map_restarted) {
    // A new session: its first keyframe starts a new map at the mapper and the loop closer.
    tracker_inbox_.startSession(++session_);
    ++map_restarts_;
    // Its frames are in the discarded map's frame: kept apart, never mixed with the new map's.
    discarded_trajectories_.push_back(std::move(trajectory_));
    trajectory_ = map::CorrectedTrajectory();
  }
  if (result.has_pose) trajectory_.add(timestamp, result.T_cam_world, result.reference_keyframe);
  if (!finished_) {
    sendKeyframes(result.keyframes);
    // Ahead of the keyframes waiting there, as the ROS tracking node's request overtakes them.
    if (const auto& request = result.relocalisation_request) {
      loop_inbox_.pushUrgent(Addressed<map::RelocalisationRequest>{
          tracker_inbox_.address(request->map_version), *request});
    }
  }
  if (!params_.mapping_thread) {
    runInline();
    drainInbox();
  }
  return result;
}

void SlamSystem::sendKeyframes(const std::vector<map::KeyframeMessage>& keyframes) {
  for (const map::KeyframeMessage& message : keyframes) {
    // Both receivers get their own copy (the image buffer is shared, read-only).
    const Envelope from = tracker_inbox_.address(message.map_version);
    mapper_inbox_.push(Addressed<map::KeyframeMessage>{from, message});
    loop_inbox_.push(Addressed<map::KeyframeMessage>{from, message});
  }
}

void SlamSystem::drainInbox() {
  for (const std::string& refusal : tracker_inbox_.drain(tracker_, trajectory_).refused)
    log("refused by the tracker: " + refusal);
}

void SlamSystem::runInline() {
  bool progress = true;
  while (progress) {
    progress = false;
    while (std::optional<MapperInput> input = mapper_inbox_.tryPop()) {
      handleSafely(std::move(*input));
      progress = true;
    }
    while (std::optional<LoopInput> input = loop_inbox_.tryPop()) {
      handleSafely(std::move(*input));
      progress = true;
    }
  }
}

void SlamSystem::publishUpdate(Addressed<map::MapUpdate> update) {
  loop_inbox_.push(update);
  tracker_inbox_.push(std::move(update));
}

template <typename Input>
void SlamSystem::handleSafely(Input input) {
  // The background threads must outlive any bad input: a refused message is logged and skipped.
  try {
    handle(std::move(input));
  } catch (const std::exception& e) {
    log(std::string("a message was skipped: ") + e.what());
  }
}

void SlamSystem::handle(MapperInput input) {
  const common::Stopwatch timer;
  if (auto* keyframe = std::get_if<Addressed<map::KeyframeMessage>>(&input)) {
    const bool had_map = mapper_.map().numKeyframes() > 0;
    MapperEndpoint::KeyframeOutcome outcome = mapper_.addKeyframe(
        keyframe->from, std::move(keyframe->message), [this] { return focalOf(camera_); });
    if (!outcome.added) {
      log("keyframe refused by the mapper: " + outcome.refusal);
      return;
    }
    if (outcome.new_map && had_map) {
      log("map restarted: the tracker discarded a young map it was lost in");
    }
    {
      std::lock_guard<std::mutex> lock(record_mutex_);
      times_.window_ba_ms.push_back(timer.ms());
    }
    publishUpdate(std::move(*outcome.update));
    return;
  }
  const auto& [from, constraint] = std::get<Addressed<loop::LoopConstraint>>(input);
  MapperEndpoint::LoopOutcome outcome = mapper_.closeLoop(from, constraint);
  if (outcome.stale) return;  // found in a discarded map
  if (!outcome.refusal.empty()) {
    log("loop constraint refused by the mapper: " + outcome.refusal);
    return;
  }
  log(outcome.statistics.describe());
  {
    std::lock_guard<std::mutex> lock(record_mutex_);
    loops_.push_back(outcome.statistics);
  }
  if (outcome.update) publishUpdate(std::move(*outcome.update));
}

void SlamSystem::handle(LoopInput input) {
  const common::Stopwatch timer;
  if (auto* keyframe = std::get_if<Addressed<map::KeyframeMessage>>(&input)) {
    LoopCloserEndpoint::KeyframeOutcome outcome = loop_closer_.addKeyframe(
        keyframe->from, std::move(keyframe->message), [this] { return camera_; });
    if (!outcome.added) {
      log("keyframe refused by the loop closer: " + outcome.refusal);
      return;
    }
    const loop::LoopDetection& detection = *outcome.detection;
    {
      std::lock_guard<std::mutex> lock(record_mutex_);
      times_.place_recognition_ms.push_back(detection.recognition_ms);
      times_.place_query_ms.push_back(detection.query_ms);
      times_.place_query_cpu_ms.push_back(detection.query_cpu_ms);
      if (detection.verification) times_.verification_ms.push_back(detection.verification_ms);
    }
    if (detection.verification || !detection.recognition.candidates.empty()) {
      log(detection.describe());
    }
    if (outcome.constraint) mapper_inbox_.push(std::move(*outcome.constraint));
  } else if (auto* update = std::get_if<Addressed<map::MapUpdate>>(&input)) {
    const LoopCloserEndpoint::UpdateOutcome outcome =
        loop_closer_.applyMapUpdate(update->from, std::move(update->message));
    if (!outcome.refusal.empty()) log("map update refused by the loop closer: " + outcome.refusal);
  } else {
    const auto& request = std::get<Addressed<map::RelocalisationRequest>>(input);
    Addressed<map::RelocalisationAnswer> answer =
        loop_closer_.relocalise(request.from, request.message);
    const map::RelocalisationAnswer& a = answer.message;
    {
      std::lock_guard<std::mutex> lock(record_mutex_);
      times_.relocalisation_ms.push_back(timer.ms());
      relocalisations_ += a.success;
    }
    log("relocalisation of frame " + std::to_string(a.frame_index) + ": " +
        (a.success ? "against keyframe " + std::to_string(a.keyframe_id) + ", " +
                         std::to_string(a.inliers) + " inliers"
                   : "failed: " + a.reason));
    tracker_inbox_.push(std::move(answer));
  }
}
void SlamSystem::log(std::string line) {
  std::lock_guard<std::mutex> lock(record_mutex_);
  log_.push_back(std::move(line));
}

std::vector<std::string> SlamSystem::takeLog() {
  std::lock_guard<std::mutex> lock(record_mutex_);
  return std::exchange(log_, {});
}

std::vector<mapping::LoopCorrectionStatistics> SlamSystem::loops() const {
  std::lock_guard<std::mutex> lock(record_mutex_);
  return loops_;
}

BackgroundTimes SlamSystem::backgroundTimes() const {
  std::lock_guard<std::mutex> lock(record_mutex_);
  return times_;
}

int SlamSystem::relocalisations() const {
  std::lock_guard<std::mutex> lock(record_mutex_);
  return relocalisations_;
}

}  // namespace scale_drift_slam::system
