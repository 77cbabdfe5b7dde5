#include "scale_drift_slam/system/loop_closer_endpoint.h"

#include <utility>

#include "keyframe_admission.h"

namespace scale_drift_slam::system {

LoopCloserEndpoint::LoopCloserEndpoint(loop::LoopCloserParams params, MessageLimits limits)
    : params_(std::move(params)), limits_(limits) {
  params_.validate();
  limits_.validate();
}

std::string LoopCloserEndpoint::admissionProblem(const Envelope& from,
                                                 const map::KeyframeMessage& keyframe) const {
  std::string problem = keyframeProblem(keyframe, limits_);
  if (problem.empty())
    problem = internal::keyframeRefusal(from, keyframe.keyframe, closer_.has_value(), session_,
                                        "loop closer's map");
  if (problem.empty() && isCurrent(from.session) && closer_->map().numKeyframes() > 0) {
    problem = keyframeIdProblem(keyframe.keyframe.id, closer_->map().keyframes().rbegin()->first,
                                limits_);
  }
  return problem;
}

LoopCloserEndpoint::KeyframeOutcome LoopCloserEndpoint::addKeyframe(const Envelope& from,
                                                                    map::KeyframeMessage keyframe,
                                                                    const CameraSource& camera) {
  KeyframeOutcome outcome;
  const map::KeyframeId id = keyframe.keyframe.id;
  outcome.refusal = admissionProblem(from, keyframe);
  if (!outcome.refusal.empty()) return outcome;
  if (!isCurrent(from.session)) {
    // A new session: the camera is checked before the old loop closer goes.
    std::shared_ptr<const geometry::CameraModel> model;
    try {
      model = camera();
    } catch (const std::exception& e) {
      outcome.refusal = "keyframe " + std::to_string(id) + " cannot start a session: " + e.what();
      return outcome;
    }
    if (!model) {
      outcome.refusal = "keyframe " + std::to_string(id) + " cannot start a session: no camera";
      return outcome;
    }
    closer_.emplace(std::move(model), params_);
    versions_.reset();
    session_ = from.session;
    outcome.new_session = true;
  } else if (closer_->map().hasKeyframe(id)) {
    outcome.refusal = "keyframe " + std::to_string(id) + " is already in the loop closer's map";
    return outcome;
  }
  // Its version in the loop closer's numbering; of a mapper not met yet: no correction is due.
  keyframe.map_version =
      versions_.toConsumer(from.mapper_id, from.map_version).value_or(closer_->mapVersion());
  outcome.detection = closer_->addKeyframe(std::move(keyframe));
  outcome.added = true;
  if (outcome.detection->constraint) {
    outcome.constraint = {address(closer_->mapVersion()), *outcome.detection->constraint};
  }
  return outcome;
}

LoopCloserEndpoint::UpdateOutcome LoopCloserEndpoint::applyMapUpdate(const Envelope& from,
                                                                     map::MapUpdate update) {
  UpdateOutcome outcome;
  if (!isCurrent(from.session)) return outcome;  // built from another session's keyframes
  outcome.refusal = mapUpdateProblem(update, limits_);
  if (!outcome.refusal.empty()) return outcome;
  const std::optional<std::uint64_t> version = versions_.toTracker(
      from.mapper_id, from.map_version, closer_->mapVersion(), &outcome.new_mapper);
  outcome.new_mapper = outcome.new_mapper && closer_->mapVersion() > 0;
  if (!version) return outcome;  // of a retired mapper
  update.map_version = *version;
  closer_->applyMapUpdate(update);
  outcome.applied = true;
  return outcome;
}

void LoopCloserEndpoint::restore(
    std::uint32_t session, std::shared_ptr<const geometry::CameraModel> camera, map::Map map,
    std::shared_ptr<const loop::Vocabulary> vocabulary, std::vector<loop::SavedPlace> places,
    std::unordered_map<map::KeyframeId, std::vector<std::uint8_t>> jpeg_images) {
  loop::LoopCloser closer(std::move(camera), params_);
  closer.restore(std::move(map), std::move(vocabulary), std::move(places), std::move(jpeg_images));
  closer_.emplace(std::move(closer));
  session_ = session;
  versions_.reset();
}

Addressed<map::RelocalisationAnswer> LoopCloserEndpoint::relocalise(
    const Envelope& from, const map::RelocalisationRequest& request) {
  const std::string problem = relocalisationRequestProblem(request, limits_);
  if (!problem.empty() || !isCurrent(from.session)) {
    map::RelocalisationAnswer answer;
    answer.frame_index = request.frame_index;
    answer.reason =
        problem.empty() ? "the loop closer holds no keyframe of this tracker session" : problem;
    return {Envelope{from.session, 0, 0}, answer};
  }
  map::RelocalisationAnswer answer = closer_->relocalise(request);
  return {address(answer.map_version), std::move(answer)};
}

}  // namespace scale_drift_slam::system
