#pragma once
// The whole SLAM in one process, as run_sequence and the end-to-end tests use it, with exactly the
// data flow of the ROS nodes: the tracking runs on the caller's thread (processFrame), the mapper
// and the loop closer each on their own thread, joined by map::MessageQueues:
//   tracker -> mapper:       keyframes                  mapper -> tracker, loop closer: map updates
//   tracker -> loop closer:  keyframes, relocalisation  loop closer -> mapper: loop constraints
//   loop closer -> tracker:  relocalisation answers
// Whatever arrives for the tracker is applied at the start of the next frame, so tracking never
// waits for the window BA, a loop correction or a relocalisation. With `mapping_thread = false`
// the mapper and the loop closer run inline after each frame (deterministic, for tests).
// Every message is addressed with its tracker session and map version (envelope.h), and each part
// applies the same session rule as the ROS nodes do (mapper_endpoint.h, loop_closer_endpoint.h,
// tracker_inbox.h): when the tracker restarts a young lost map (FrameResult::map_restarted) it
// starts a new session; its first keyframe starts a new map at the mapper and the loop closer, and
// anything made from the old map that is still under way (map updates, loop constraints,
// relocalisation answers) is dropped on arrival.
// Owns the Tracker, the Mapper, the LoopCloser, the queues and the threads.

#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include "scale_drift_slam/common/message_queue.h"
#include "scale_drift_slam/geometry/camera_model.h"
#include "scale_drift_slam/map/corrected_trajectory.h"
#include "scale_drift_slam/map/keyframe_message.h"
#include "scale_drift_slam/system/envelope.h"
#include "scale_drift_slam/system/loop_closer_endpoint.h"
#include "scale_drift_slam/system/map_snapshot.h"
#include "scale_drift_slam/system/mapper_endpoint.h"
#include "scale_drift_slam/system/slam_params.h"
#include "scale_drift_slam/system/tracker_inbox.h"
#include "scale_drift_slam/tracking/tracker.h"

namespace scale_drift_slam::system {

/// Figures of the background work; complete after finish().
struct BackgroundTimes {
  std::vector<double> window_ba_ms;          ///< Per keyframe.
  std::vector<double> place_recognition_ms;  ///< Per keyframe: ORB extraction and query.
  std::vector<double> place_query_ms;        ///< Per keyframe: the query alone.
  std::vector<double> place_query_cpu_ms;    ///< Per keyframe: the query's CPU time.
  std::vector<double> verification_ms;       ///< Per verified candidate.
  std::vector<double> relocalisation_ms;     ///< Per request.
};

class SlamSystem {
 public:
  SlamSystem(const std::shared_ptr<const geometry::CameraModel>& camera, const SlamParams& params);
  ~SlamSystem();
  SlamSystem(const SlamSystem&) = delete;
  SlamSystem& operator=(const SlamSystem&) = delete;

  /// Applies what arrived for the tracker, tracks the frame, hands keyframes and relocalisation
  /// requests on.
  tracking::FrameResult processFrame(double timestamp, const cv::Mat& image,
                                     features::PixelEncoding encoding);
  /// Lets the mapper and the loop closer finish their queues, stops the threads and applies the
  /// last updates to the trajectory. Idempotent.
  void finish();

  /// Everything a later run needs to go on in this map (map_snapshot.h); only after finish().
  /// Throws std::logic_error before finish() and when there is no map.
  MapSnapshot snapshot() const;
  /// Starts from a saved map (call before the first frame; throws std::logic_error after): the
  /// tracker is lost in it and relocalises by place recognition; its trajectory is in the saved
  /// map's frame. `localization_only`: no keyframe is added, the map does not change; otherwise
  /// this session's keyframes extend the map from its first relocalisation on. Throws
  /// std::invalid_argument on an inconsistent snapshot; nothing changes then.
  void restore(MapSnapshot snapshot, bool localization_only);
  /// Keyframes in the map restored at the start (0: none restored).
  std::size_t restoredKeyframes() const { return restored_keyframes_; }

  /// The mapper's map; only after finish() (or without threads).
  const map::Map& map() const { return mapper_.map(); }
  const tracking::Tracker& tracker() const { return tracker_; }
  /// Every tracked frame, corrected by the loop closures applied so far.
  const map::CorrectedTrajectory& trajectory() const { return trajectory_; }
  /// The loops the loop closer verified, as the mapper applied (or refused) them.
  std::vector<mapping::LoopCorrectionStatistics> loops() const;
  BackgroundTimes backgroundTimes() const;
  int relocalisations() const;
  /// Keyframes waiting in the mapper's queue now (the window BA's backlog; 0 when it keeps up).
  std::size_t mapperBacklog() const { return mapper_inbox_.size(); }
  /// Milliseconds the last processFrame() spent applying what arrived for the tracker (map
  /// updates, loop corrections, relocalisation answers) before tracking the frame.
  double lastInboxMs() const { return last_inbox_ms_; }
  /// The same in CPU time of the calling (tracking) thread.
  double lastInboxCpuMs() const { return last_inbox_cpu_ms_; }
  /// Young lost maps the tracker discarded to initialise again.
  int mapRestarts() const { return map_restarts_; }
  /// The trajectories of the discarded maps (map 0, 1, ...), as corrected until each was
  /// discarded; trajectory() is the current map's (number mapRestarts()).
  const std::vector<map::CorrectedTrajectory>& discardedTrajectories() const {
    return discarded_trajectories_;
  }
  /// Log lines of the background threads (loops found or refused, relocalisation answers) since
  /// the last call.
  std::vector<std::string> takeLog();

 private:
  using MapperInput =
      std::variant<Addressed<map::KeyframeMessage>, Addressed<loop::LoopConstraint>>;
  using LoopInput = std::variant<Addressed<map::KeyframeMessage>, Addressed<map::MapUpdate>,
                                 Addressed<map::RelocalisationRequest>>;

  void runInline();
  /// Applies what the tracker's inbox holds; logs the messages it refused.
  void drainInbox();
  /// Sends keyframes to the mapper and the loop closer.
  void sendKeyframes(const std::vector<map::KeyframeMessage>& keyframes);
  template <typename Input>
  void handleSafely(Input input);
  void handle(MapperInput input);
  void handle(LoopInput input);
  void publishUpdate(Addressed<map::MapUpdate> update);
  void log(std::string line);

  SlamParams params_;
  std::shared_ptr<const geometry::CameraModel> camera_;
  tracking::Tracker tracker_;
  MapperEndpoint mapper_;           ///< The mapping thread's.
  LoopCloserEndpoint loop_closer_;  ///< The loop thread's.
  map::CorrectedTrajectory trajectory_;
  std::vector<map::CorrectedTrajectory> discarded_trajectories_;
  std::uint32_t session_ = 1;  ///< The tracker's; a new one at each map restart.
  common::MessageQueue<MapperInput> mapper_inbox_;
  common::MessageQueue<LoopInput> loop_inbox_;
  TrackerInbox tracker_inbox_{params_.messages};
  mutable std::mutex record_mutex_;  ///< Guards the records below (written by the threads).
  std::vector<mapping::LoopCorrectionStatistics> loops_;
  BackgroundTimes times_;
  std::vector<std::string> log_;
  int relocalisations_ = 0;
  int map_restarts_ = 0;
  std::size_t restored_keyframes_ = 0;
  bool started_ = false;  ///< A frame was processed.
  double last_inbox_ms_ = 0.0, last_inbox_cpu_ms_ = 0.0;
  std::thread mapping_thread_, loop_thread_;
  bool finished_ = false;
};

}  // namespace scale_drift_slam::system
