#include "scale_drift_slam/mapping/slam_system.h"

#include <chrono>

namespace scale_drift_slam::mapping {

void SlamParams::validate() const {
  tracker.validate();
  mapper.validate();
}

namespace {

double focalOf(const std::shared_ptr<const geometry::CameraModel>& camera) {
  if (!camera) throw std::invalid_argument("the SLAM needs a camera model");
  return 0.5 * (camera->calibration().fx + camera->calibration().fy);
}

}  // namespace

SlamSystem::SlamSystem(const std::shared_ptr<const geometry::CameraModel>& camera,
                       const SlamParams& params)
    : params_(params), tracker_(camera, params.tracker), mapper_(params.mapper, focalOf(camera)) {
  if (params_.mapping_thread) thread_ = std::thread([this] { mappingLoop(); });
}

SlamSystem::~SlamSystem() {
  finish();
}

void SlamSystem::finish() {
  if (finished_) return;
  finished_ = true;
  keyframes_.close();
  if (thread_.joinable()) thread_.join();
}

tracking::FrameResult SlamSystem::processFrame(double timestamp, const cv::Mat& image,
                                               tracking::PixelEncoding encoding) {
  while (std::optional<map::MapUpdate> update = updates_.tryPop())
    tracker_.applyMapUpdate(*update);
  tracking::FrameResult result = tracker_.processFrame(timestamp, image, encoding);
  for (map::KeyframeMessage& message : result.keyframes) {
    if (params_.mapping_thread && !finished_) {
      // The tracker keeps its own copy of everything it needs; the message goes by value.
      keyframes_.push(message);
    } else {
      runMapper(message);
    }
  }
  if (!params_.mapping_thread) {
    while (std::optional<map::MapUpdate> update = updates_.tryPop()) {
      tracker_.applyMapUpdate(*update);
    }
  }
  return result;
}

void SlamSystem::mappingLoop() {
  while (std::optional<map::KeyframeMessage> message = keyframes_.waitPop())
    runMapper(*message);
}

void SlamSystem::runMapper(const map::KeyframeMessage& message) {
  BundleStatistics statistics;
  const auto start = std::chrono::steady_clock::now();
  map::MapUpdate update = mapper_.addKeyframe(message, &statistics);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  {
    std::lock_guard<std::mutex> lock(times_mutex_);
    window_ba_ms_.push_back(ms);
  }
  updates_.push(std::move(update));
}

std::vector<double> SlamSystem::windowBaTimesMs() const {
  std::lock_guard<std::mutex> lock(times_mutex_);
  return window_ba_ms_;
}

}  // namespace scale_drift_slam::mapping
