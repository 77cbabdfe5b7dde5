#pragma once
// The mapper as the tracker and the loop closer reach it: addressed keyframes and loop
// constraints in (envelope.h), addressed map updates out. It owns the session rule of the mapper's
// side: a new tracker session's first keyframe (id 0) starts a new map (the tracker was reset or
// started a new map), checked before anything is thrown away; no other keyframe of another session
// replaces the map (a stray or forged one); a constraint of another session is
// refused; every message is validated first (message_validation.h: content, and a keyframe id far
// ahead of the map's newest) and a refused one changes nothing; every update leaves in this
// mapper's numbering (its id and map version). A reset takes a new mapper id, so that receivers
// know its versions count from 0 again. Driven by system::SlamSystem's mapping thread offline and
// by the ROS mapping node's callbacks: one thread at a time.

#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "scale_drift_slam/features/bundle_statistics.h"
#include "scale_drift_slam/mapping/mapper.h"
#include "scale_drift_slam/system/envelope.h"
#include "scale_drift_slam/system/message_validation.h"

namespace scale_drift_slam::system {

class MapperEndpoint {
 public:
  /// `limits`: what a message must pass to be taken (message_validation.h).
  MapperEndpoint(mapping::MapperParams params, std::uint32_t mapper_id, MessageLimits limits = {});

  struct KeyframeOutcome {
    bool added = false;
    bool new_map = false;  ///< It started a new map (the first, or of a new tracker session).
    std::string refusal;   ///< Why it was not added.
    std::optional<Addressed<map::MapUpdate>> update;
    features::BundleStatistics window_ba;
  };
  /// Adds a keyframe. `focal_length_px` is asked only when the keyframe starts a new map; when it
  /// throws, or the keyframe is unusable, nothing changes (the old map stays).
  KeyframeOutcome addKeyframe(const Envelope& from, map::KeyframeMessage keyframe,
                              const std::function<double()>& focal_length_px);

  struct LoopOutcome {
    bool stale = false;   ///< Of another tracker session (a discarded map): dropped.
    std::string refusal;  ///< Why an invalid constraint was refused (message_validation.h).
    mapping::LoopCorrectionStatistics statistics;  ///< `applied`, or the reason why not.
    std::optional<Addressed<map::MapUpdate>> update;
  };
  LoopOutcome closeLoop(const Envelope& from, const loop::LoopConstraint& constraint);

  /// Takes a saved map as the map of tracker session `session` (its keyframes go on in it).
  void restore(std::uint32_t session, double focal_length_px, map::Map map,
               std::vector<loop::PoseGraphEdge> loop_edges);

  /// Forgets the map; the next keyframe starts a new one. `new_mapper_id` must differ from the
  /// ids used before (receivers retire the old one).
  void reset(std::uint32_t new_mapper_id);

  /// The map; empty before the first keyframe.
  const map::Map& map() const { return mapper_ ? mapper_->map() : empty_map_; }
  /// Loop edges applied so far.
  std::vector<loop::PoseGraphEdge> loopEdges() const;
  std::uint32_t session() const { return session_; }
  std::uint32_t mapperId() const { return mapper_id_; }

 private:
  bool isCurrent(std::uint32_t session) const { return mapper_ && session == session_; }
  Addressed<map::MapUpdate> address(map::MapUpdate update) const;

  std::string admissionProblem(const Envelope& from, const map::KeyframeMessage& keyframe) const;

  mapping::MapperParams params_;
  MessageLimits limits_;
  std::uint32_t mapper_id_;
  std::uint32_t session_ = 0;
  std::optional<mapping::Mapper> mapper_;  ///< Made at the first keyframe of a session.
  map::Map empty_map_;
};

}  // namespace scale_drift_slam::system
