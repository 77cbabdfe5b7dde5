#include "scale_drift_slam/system/tracker_inbox.h"

namespace scale_drift_slam::system {
namespace {

std::optional<map::KeyframeId> newestKeyframe(const tracking::Tracker& tracker) {
  const auto& keyframes = tracker.trackingMap().keyframes();
  if (keyframes.empty()) return std::nullopt;
  return keyframes.rbegin()->first;
}

}  // namespace

std::string TrackerInbox::problem(const Addressed<map::MapUpdate>& update,
                                  const tracking::Tracker& tracker) const {
  std::string problem = mapUpdateProblem(update.message, limits_);
  if (problem.empty()) problem = trackerIdsProblem(update.message, newestKeyframe(tracker));
  return problem;
}

std::string TrackerInbox::problem(const Addressed<map::RelocalisationAnswer>& answer,
                                  const tracking::Tracker& tracker) const {
  std::string problem = relocalisationAnswerProblem(answer.message, limits_);
  if (problem.empty()) problem = trackerIdsProblem(answer.message, newestKeyframe(tracker));
  return problem;
}

TrackerInbox::Report TrackerInbox::drain(tracking::Tracker& tracker,
                                         map::CorrectedTrajectory& trajectory) {
  Report report;
  while (auto received = queue_.tryPop()) {
    std::string refusal;
    if (auto* update = std::get_if<Addressed<map::MapUpdate>>(&*received)) {
      if (update->from.session != session_) continue;
      refusal = problem(*update, tracker);
      if (refusal.empty()) apply(*update, tracker, trajectory, &report);
    } else {
      auto& answer = std::get<Addressed<map::RelocalisationAnswer>>(*received);
      if (answer.from.session != session_) continue;
      refusal = problem(answer, tracker);
      if (refusal.empty()) apply(answer, tracker, &report);
    }
    if (!refusal.empty()) report.refused.push_back(std::move(refusal));
  }
  return report;
}

void TrackerInbox::apply(Addressed<map::MapUpdate>& received, tracking::Tracker& tracker,
                         map::CorrectedTrajectory& trajectory, Report* report) {
  bool new_mapper = false;
  const std::uint64_t tracker_version = tracker.trackingMap().version();
  const std::optional<std::uint64_t> version = versions_.toTracker(
      received.from.mapper_id, received.from.map_version, tracker_version, &new_mapper);
  report->new_mapper |= new_mapper && tracker_version > 0;
  if (!version || *version < tracker_version) return;  // stale, or of a retired mapper
  received.message.map_version = *version;
  tracker.applyMapUpdate(received.message);
  trajectory.apply(received.message);
}

void TrackerInbox::apply(Addressed<map::RelocalisationAnswer>& received, tracking::Tracker& tracker,
                         Report* report) {
  map::RelocalisationAnswer& answer = received.message;
  // In the tracker's numbering; a mapper not met yet is newer than anything applied here.
  answer.map_version = versions_.toConsumer(received.from.mapper_id, received.from.map_version)
                           .value_or(tracker.trackingMap().version());
  if (tracker.applyRelocalisation(answer)) {
    report->relocalised = answer;
  } else if (!answer.success) {
    report->relocalisation_failure = answer.reason;
  }
}

void TrackerInbox::startSession(std::uint32_t session) {
  while (queue_.tryPop()) {
  }
  session_ = session;
  versions_.reset();
}

}  // namespace scale_drift_slam::system
