#include "scale_drift_slam/system/mapper_endpoint.h"

#include <cmath>
#include <utility>

#include "keyframe_admission.h"

namespace scale_drift_slam::system {

MapperEndpoint::MapperEndpoint(mapping::MapperParams params, std::uint32_t mapper_id,
                               MessageLimits limits)
    : params_(std::move(params)), limits_(limits), mapper_id_(mapper_id) {
  params_.validate();
  limits_.validate();
}

std::string MapperEndpoint::admissionProblem(const Envelope& from,
                                             const map::KeyframeMessage& keyframe) const {
  std::string problem = keyframeProblem(keyframe, limits_);
  if (problem.empty())
    problem =
        internal::keyframeRefusal(from, keyframe.keyframe, mapper_.has_value(), session_, "map");
  if (problem.empty() && isCurrent(from.session) && mapper_->map().numKeyframes() > 0) {
    problem = keyframeIdProblem(keyframe.keyframe.id, mapper_->map().keyframes().rbegin()->first,
                                limits_);
  }
  return problem;
}

MapperEndpoint::KeyframeOutcome MapperEndpoint::addKeyframe(
    const Envelope& from, map::KeyframeMessage keyframe,
    const std::function<double()>& focal_length_px) {
  KeyframeOutcome outcome;
  const map::KeyframeId id = keyframe.keyframe.id;
  outcome.refusal = admissionProblem(from, keyframe);
  if (!outcome.refusal.empty()) return outcome;
  if (!isCurrent(from.session)) {
    // A new map: everything that can refuse the keyframe is checked before the old one goes.
    double focal = 0.0;
    try {
      focal = focal_length_px();
    } catch (const std::exception& e) {
      outcome.refusal = "keyframe " + std::to_string(id) + " cannot start a map: " + e.what();
      return outcome;
    }
    if (!(std::isfinite(focal) && focal > 0.0)) {
      outcome.refusal = "keyframe " + std::to_string(id) + " cannot start a map: focal length " +
                        std::to_string(focal);
      return outcome;
    }
    mapper_.emplace(params_, focal);
    session_ = from.session;
    outcome.new_map = true;
  } else if (mapper_->map().hasKeyframe(id)) {
    outcome.refusal = "keyframe " + std::to_string(id) + " is already in the map";
    return outcome;
  }
  // Its version in this mapper's numbering; made before this mapper's first update: 0.
  keyframe.map_version = from.mapper_id == mapper_id_ ? from.map_version : 0;
  outcome.update = address(mapper_->addKeyframe(std::move(keyframe), &outcome.window_ba));
  outcome.added = true;
  return outcome;
}

MapperEndpoint::LoopOutcome MapperEndpoint::closeLoop(const Envelope& from,
                                                      const loop::LoopConstraint& constraint) {
  LoopOutcome outcome;
  outcome.statistics.constraint = constraint;
  outcome.refusal = loopConstraintProblem(constraint, limits_);
  if (!outcome.refusal.empty()) {
    outcome.statistics.reason = outcome.refusal;
    return outcome;
  }
  if (!isCurrent(from.session)) {
    outcome.stale = true;
    outcome.statistics.reason =
        "of tracker session " + std::to_string(from.session) +
        (mapper_ ? ", the map is of session " + std::to_string(session_) : ", there is no map");
    return outcome;
  }
  map::MapUpdate update = mapper_->closeLoop(constraint, &outcome.statistics);
  if (outcome.statistics.applied) outcome.update = address(std::move(update));
  return outcome;
}

void MapperEndpoint::restore(std::uint32_t session, double focal_length_px, map::Map map,
                             std::vector<loop::PoseGraphEdge> loop_edges) {
  mapper_.emplace(params_, focal_length_px, std::move(map), std::move(loop_edges));
  session_ = session;
}

void MapperEndpoint::reset(std::uint32_t new_mapper_id) {
  mapper_.reset();
  mapper_id_ = new_mapper_id;
}

std::vector<loop::PoseGraphEdge> MapperEndpoint::loopEdges() const {
  return mapper_ ? mapper_->loopEdges() : std::vector<loop::PoseGraphEdge>{};
}

Addressed<map::MapUpdate> MapperEndpoint::address(map::MapUpdate update) const {
  const Envelope from{session_, mapper_id_, update.map_version};
  return {from, std::move(update)};
}

}  // namespace scale_drift_slam::system
