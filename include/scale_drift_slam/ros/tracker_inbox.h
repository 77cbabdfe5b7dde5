#pragma once
// What the tracking node's tracker receives from the other nodes: map updates (mapping node) and
// relocalisation answers (loop-closure node). The subscriber thread converts and queues them; the
// camera thread applies them between frames, in arrival order, exactly as
// system::SlamSystem::drainTrackerInbox does offline, so the camera never waits for the other
// nodes. Also owns the map-version bookkeeping of a tracker session (ros/map_versions.h): messages
// of another session are dropped, a restarted mapper continues above the tracker's version, stale
// updates are skipped, and versions reported to other nodes are in the current mapper's numbering.

#include <cstdint>
#include <optional>
#include <string>
#include <variant>

#include "scale_drift_slam/MapUpdate.h"
#include "scale_drift_slam/RelocalisationAnswer.h"
#include "scale_drift_slam/common/message_queue.h"
#include "scale_drift_slam/map/corrected_trajectory.h"
#include "scale_drift_slam/map/keyframe_message.h"
#include "scale_drift_slam/ros/map_versions.h"
#include "scale_drift_slam/tracking/tracker.h"

namespace scale_drift_slam::ros_conversions {

class TrackerInbox {
 public:
  /// Subscriber thread: converts and queues. Throws std::invalid_argument for a malformed message
  /// (nothing is queued).
  void push(const scale_drift_slam::MapUpdate& msg);
  void push(const scale_drift_slam::RelocalisationAnswer& msg);

  /// What one drain did, for the node's log.
  struct Report {
    bool new_mapper = false;  ///< Updates of a new mapper (restarted or reset) arrived.
    std::optional<map::RelocalisationAnswer> relocalised;  ///< An answer the tracker took.
    std::string relocalisation_failure;  ///< Why the last failed answer of the session failed.
  };
  /// Camera thread, between frames: applies what is queued for `session` to the tracker; map
  /// updates also to the trajectory (a loop correction moves its frames with their keyframes).
  Report drain(std::uint32_t session, tracking::Tracker& tracker,
               map::CorrectedTrajectory& trajectory);
  /// Camera thread: a new tracker session; forgets what is queued and every mapper.
  void reset();

  /// Camera thread: a tracker version as other nodes need it (keyframes, relocalisation
  /// requests): the current mapper and the version in its numbering (0, 0: none applied yet).
  std::uint32_t mapperId() const { return versions_.mapperId(); }
  std::uint64_t toMapper(std::uint64_t tracker_version) const {
    return versions_.toMapper(tracker_version);
  }

 private:
  struct Update {
    std::uint32_t session = 0, mapper_id = 0;
    map::MapUpdate update;
  };
  struct Answer {
    std::uint32_t session = 0, mapper_id = 0;  ///< map_version is in mapper_id's numbering.
    map::RelocalisationAnswer answer;
  };
  void apply(Update& received, tracking::Tracker& tracker, map::CorrectedTrajectory& trajectory,
             Report* report);
  void apply(Answer& received, tracking::Tracker& tracker, Report* report);

  common::MessageQueue<std::variant<Update, Answer>> queue_;
  MapVersionTranslator versions_;  ///< Camera thread only.
};

}  // namespace scale_drift_slam::ros_conversions
