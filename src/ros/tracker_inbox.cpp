#include "scale_drift_slam/ros/tracker_inbox.h"

#include "scale_drift_slam/ros/slam_messages.h"

namespace scale_drift_slam::ros_conversions {

void TrackerInbox::push(const scale_drift_slam::MapUpdate& msg) {
  queue_.push(Update{msg.session, msg.mapper_id, fromMapUpdateMsg(msg)});
}

void TrackerInbox::push(const scale_drift_slam::RelocalisationAnswer& msg) {
  queue_.push(Answer{msg.session, msg.mapper_id, fromRelocalisationAnswerMsg(msg)});
}

TrackerInbox::Report TrackerInbox::drain(std::uint32_t session, tracking::Tracker& tracker,
                                         map::CorrectedTrajectory& trajectory) {
  Report report;
  while (std::optional<std::variant<Update, Answer>> received = queue_.tryPop()) {
    if (auto* update = std::get_if<Update>(&*received)) {
      if (update->session == session) apply(*update, tracker, trajectory, &report);
    } else {
      Answer& answer = std::get<Answer>(*received);
      if (answer.session == session) apply(answer, tracker, &report);
    }
  }
  return report;
}

void TrackerInbox::apply(Update& received, tracking::Tracker& tracker,
                         map::CorrectedTrajectory& trajectory, Report* report) {
  bool new_mapper = false;
  const std::uint64_t tracker_version = tracker.trackingMap().version();
  const std::optional<std::uint64_t> version = versions_.toTracker(
      received.mapper_id, received.update.map_version, tracker_version, &new_mapper);
  report->new_mapper |= new_mapper && tracker_version > 0;
  if (!version || *version < tracker_version) return;  // stale, or of a retired mapper
  received.update.map_version = *version;
  tracker.applyMapUpdate(received.update);
  trajectory.apply(received.update);
}

void TrackerInbox::apply(Answer& received, tracking::Tracker& tracker, Report* report) {
  map::RelocalisationAnswer& answer = received.answer;
  // In the tracker's numbering; a mapper not met yet is newer than anything applied here.
  answer.map_version = versions_.toConsumer(received.mapper_id, answer.map_version)
                           .value_or(tracker.trackingMap().version());
  if (tracker.applyRelocalisation(answer)) {
    report->relocalised = answer;
  } else if (!answer.success) {
    report->relocalisation_failure = answer.reason;
  }
}

void TrackerInbox::reset() {
  while (queue_.tryPop()) {
  }
  versions_.reset();
}

}  // namespace scale_drift_slam::ros_conversions
