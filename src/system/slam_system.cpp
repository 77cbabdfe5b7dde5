#include "scale_drift_slam/system/slam_system.h"

#include <utility>

#include "scale_drift_slam/common/stopwatch.h"

namespace scale_drift_slam::system {

namespace {

double focalOf(const std::shared_ptr<const geometry::CameraModel>& camera) {
  if (!camera) throw std::invalid_argument("the SLAM needs a camera model");
  return camera->calibration().meanFocalLength();
}

}  // namespace

SlamSystem::SlamSystem(const std::shared_ptr<const geometry::CameraModel>& camera,
                       const SlamParams& params)
    : params_(params),
      camera_(camera),
      tracker_(camera, params.tracker),
      mapper_(params.mapper, focalOf(camera)),
      loop_closer_(camera, params.loop) {
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
  drainTrackerInbox();
}

tracking::FrameResult SlamSystem::processFrame(double timestamp, const cv::Mat& image,
                                               features::PixelEncoding encoding) {
  drainTrackerInbox();
  tracking::FrameResult result = tracker_.processFrame(timestamp, image, encoding);
  if (result.map_restarted) {
    ++tracker_generation_;
    ++map_restarts_;
    trajectory_ = map::CorrectedTrajectory();  // its frames are in the discarded map's frame
    if (!finished_) {
      mapper_inbox_.push(MapRestart{});
      loop_inbox_.push(MapRestart{});
    }
  }
  if (result.has_pose) trajectory_.add(timestamp, result.T_cam_world, result.reference_keyframe);
  if (!finished_) {
    for (const map::KeyframeMessage& message : result.keyframes) {
      // Both receivers get their own copy (the image buffer is shared, read-only).
      mapper_inbox_.push(message);
      loop_inbox_.push(message);
    }
    // Ahead of the keyframes waiting there, as the ROS tracking node's request overtakes them.
    if (result.relocalisation_request) loop_inbox_.pushUrgent(*result.relocalisation_request);
  }
  if (!params_.mapping_thread) {
    runInline();
    drainTrackerInbox();
  }
  return result;
}

void SlamSystem::drainTrackerInbox() {
  while (std::optional<TrackerInput> input = tracker_inbox_.tryPop()) {
    if (input->generation != tracker_generation_) continue;  // about a discarded map
    if (const auto* update = std::get_if<map::MapUpdate>(&input->message)) {
      tracker_.applyMapUpdate(*update);
      trajectory_.apply(*update);
    } else {
      tracker_.applyRelocalisation(std::get<map::RelocalisationAnswer>(input->message));
    }
  }
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

void SlamSystem::publishUpdate(map::MapUpdate update) {
  loop_inbox_.push(OfGeneration<map::MapUpdate>{mapper_generation_, update});
  tracker_inbox_.push(TrackerInput{mapper_generation_, std::move(update)});
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
  if (auto* message = std::get_if<map::KeyframeMessage>(&input)) {
    map::MapUpdate update = mapper_.addKeyframe(std::move(*message));
    {
      std::lock_guard<std::mutex> lock(record_mutex_);
      times_.window_ba_ms.push_back(timer.ms());
    }
    publishUpdate(std::move(update));
    return;
  }
  if (std::holds_alternative<MapRestart>(input)) {
    ++mapper_generation_;
    mapper_ = mapping::Mapper(params_.mapper, focalOf(camera_));
    log("map restarted: the tracker discarded a young map it was lost in");
    return;
  }
  const auto& [generation, constraint] = std::get<OfGeneration<loop::LoopConstraint>>(input);
  if (generation != mapper_generation_) return;  // found in a discarded map
  mapping::LoopCorrectionStatistics c;
  map::MapUpdate update = mapper_.closeLoop(constraint, &c);
  log(c.describe());
  {
    std::lock_guard<std::mutex> lock(record_mutex_);
    loops_.push_back(c);
  }
  if (c.applied) publishUpdate(std::move(update));
}

void SlamSystem::handle(LoopInput input) {
  const common::Stopwatch timer;
  if (auto* message = std::get_if<map::KeyframeMessage>(&input)) {
    const loop::LoopDetection detection = loop_closer_.addKeyframe(std::move(*message));
    {
      std::lock_guard<std::mutex> lock(record_mutex_);
      times_.place_recognition_ms.push_back(detection.recognition_ms);
      if (detection.verification) times_.verification_ms.push_back(detection.verification_ms);
    }
    if (detection.verification || !detection.recognition.candidates.empty()) {
      log(detection.describe());
    }
    if (detection.constraint) {
      mapper_inbox_.push(
          OfGeneration<loop::LoopConstraint>{loop_generation_, *detection.constraint});
    }
  } else if (auto* update = std::get_if<OfGeneration<map::MapUpdate>>(&input)) {
    if (update->generation == loop_generation_) loop_closer_.applyMapUpdate(update->message);
  } else if (std::holds_alternative<MapRestart>(input)) {
    ++loop_generation_;
    loop_closer_ = loop::LoopCloser(camera_, params_.loop);
  } else {
    const map::RelocalisationAnswer answer =
        loop_closer_.relocalise(std::get<map::RelocalisationRequest>(input));
    {
      std::lock_guard<std::mutex> lock(record_mutex_);
      times_.relocalisation_ms.push_back(timer.ms());
      relocalisations_ += answer.success;
    }
    log("relocalisation of frame " + std::to_string(answer.frame_index) + ": " +
        (answer.success ? "against keyframe " + std::to_string(answer.keyframe_id) + ", " +
                              std::to_string(answer.inliers) + " inliers"
                        : "failed: " + answer.reason));
    tracker_inbox_.push(TrackerInput{loop_generation_, answer});
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
