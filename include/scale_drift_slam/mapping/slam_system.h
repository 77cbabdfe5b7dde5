#pragma once
// The whole SLAM in one process, as run_sequence and the end-to-end tests use it: the tracking
// runs on the caller's thread (processFrame), the mapper on its own thread, joined by two
// map::MessageQueues (keyframes out, map updates back), exactly the data flow of the ROS nodes.
// Map updates are applied at the start of the next frame, so tracking never waits for the window
// BA. With `mapping_thread = false` the mapper runs inline after each keyframe (deterministic,
// for tests). Owns the Tracker, the Mapper and the thread.

#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "scale_drift_slam/geometry/camera_model.h"
#include "scale_drift_slam/map/keyframe_message.h"
#include "scale_drift_slam/map/message_queue.h"
#include "scale_drift_slam/mapping/mapper.h"
#include "scale_drift_slam/tracking/tracker.h"

namespace scale_drift_slam::mapping {

struct SlamParams {
  tracking::TrackerParams tracker;
  MapperParams mapper;
  bool mapping_thread = true;
  void validate() const;
};

class SlamSystem {
 public:
  SlamSystem(const std::shared_ptr<const geometry::CameraModel>& camera, const SlamParams& params);
  ~SlamSystem();
  SlamSystem(const SlamSystem&) = delete;
  SlamSystem& operator=(const SlamSystem&) = delete;

  /// Applies the map updates that arrived, tracks the frame, hands new keyframes to the mapper.
  tracking::FrameResult processFrame(double timestamp, const cv::Mat& image,
                                     tracking::PixelEncoding encoding);
  /// Lets the mapper finish the queued keyframes and stops its thread. Idempotent.
  void finish();

  /// The mapper's map; only after finish() (or without a mapping thread).
  const map::Map& map() const { return mapper_.map(); }
  const tracking::Tracker& tracker() const { return tracker_; }
  /// Window BA time per keyframe (ms); complete after finish().
  std::vector<double> windowBaTimesMs() const;

 private:
  void mappingLoop();
  void runMapper(const map::KeyframeMessage& message);

  SlamParams params_;
  tracking::Tracker tracker_;
  Mapper mapper_;
  map::MessageQueue<map::KeyframeMessage> keyframes_;
  map::MessageQueue<map::MapUpdate> updates_;
  mutable std::mutex times_mutex_;
  std::vector<double> window_ba_ms_;
  std::thread thread_;
  bool finished_ = false;
};

}  // namespace scale_drift_slam::mapping
