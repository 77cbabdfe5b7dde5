#pragma once
// What the tracker receives: map updates (from the mapper) and relocalisation answers (from the
// loop closer), addressed (envelope.h). Any thread pushes; the tracker's thread drains between
// frames and applies them in arrival order, so the camera never waits for the other parts. It
// keeps the tracker session's map-version bookkeeping: messages of another session are dropped,
// a restarted mapper's updates continue above the tracker's version, stale updates are skipped,
// and the versions the tracker reports (keyframes, relocalisation requests) are addressed in the
// current mapper's numbering. Every message is validated before it is applied
// (message_validation.h: content, and keyframe ids the tracker never made); a refused one is
// reported and changes nothing. Used by system::SlamSystem and by the ROS tracking node alike.

#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "scale_drift_slam/common/message_queue.h"
#include "scale_drift_slam/map/corrected_trajectory.h"
#include "scale_drift_slam/map/keyframe_message.h"
#include "scale_drift_slam/system/envelope.h"
#include "scale_drift_slam/system/map_versions.h"
#include "scale_drift_slam/system/message_validation.h"
#include "scale_drift_slam/tracking/tracker.h"

namespace scale_drift_slam::system {

class TrackerInbox {
 public:
  /// `limits`: what a message must pass to be applied (message_validation.h).
  explicit TrackerInbox(MessageLimits limits = {}) : limits_(limits) { limits_.validate(); }

  /// Any thread.
  void push(Addressed<map::MapUpdate> update) { queue_.push(std::move(update)); }
  void push(Addressed<map::RelocalisationAnswer> answer) { queue_.push(std::move(answer)); }

  /// What one drain did, for the log.
  struct Report {
    bool new_mapper = false;  ///< Updates of a new mapper (restarted or reset) arrived.
    std::optional<map::RelocalisationAnswer> relocalised;  ///< An answer the tracker took.
    std::string relocalisation_failure;  ///< Why the last failed answer of the session failed.
    std::vector<std::string> refused;    ///< Invalid messages of the session, why (none applied).
  };
  /// Tracker thread, between frames: applies what is queued for the current session to the
  /// tracker; map updates also to the trajectory (a loop correction moves its frames with their
  /// keyframes).
  Report drain(tracking::Tracker& tracker, map::CorrectedTrajectory& trajectory);

  /// Tracker thread: a new tracker session (a new map); forgets what is queued and every mapper.
  void startSession(std::uint32_t session);
  std::uint32_t session() const { return session_; }
  /// Tracker thread: the address of a message made at tracker map version `tracker_version`.
  Envelope address(std::uint64_t tracker_version) const {
    return {session_, versions_.mapperId(), versions_.toMapper(tracker_version)};
  }

 private:
  void apply(Addressed<map::MapUpdate>& received, tracking::Tracker& tracker,
             map::CorrectedTrajectory& trajectory, Report* report);
  void apply(Addressed<map::RelocalisationAnswer>& received, tracking::Tracker& tracker,
             Report* report);

  /// Why a message of the current session may not reach `tracker` (empty: it may).
  std::string problem(const Addressed<map::MapUpdate>& update,
                      const tracking::Tracker& tracker) const;
  std::string problem(const Addressed<map::RelocalisationAnswer>& answer,
                      const tracking::Tracker& tracker) const;

  MessageLimits limits_;
  common::MessageQueue<
      std::variant<Addressed<map::MapUpdate>, Addressed<map::RelocalisationAnswer>>>
      queue_;
  // Tracker thread only:
  std::uint32_t session_ = 0;
  MapVersionTranslator versions_;
};

}  // namespace scale_drift_slam::system
