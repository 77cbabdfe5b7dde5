#pragma once
// Applies a solved pose graph to the map (doc/algorithm.md, "Loop closure correction"):
//   points:    x' = (S_r^new)^-1 (T_r^old x), r = the point's reference keyframe (the point keeps
//              its coordinates in that keyframe and moves with it, scale included);
//   keyframes: T' = S^new as a rigid pose: rotation kept, translation t / s (same camera centre).
// Keyframes without a corrected pose, and points whose reference keyframe has none, are left
// unchanged.

#include <cstddef>
#include <map>

#include "scale_drift_slam/geometry/sim3.h"
#include "scale_drift_slam/map/map.h"

namespace scale_drift_slam::loop {

struct MapCorrectionStats {
  std::size_t keyframes_corrected = 0;
  std::size_t points_moved = 0;
};

/// Corrects `map` in place with the solved similarities S_kf_world (e.g.
/// PoseGraphResult::S_kf_world) and bumps its version. Throws std::invalid_argument, leaving the
/// map untouched, when a pose is not finite or names a keyframe that is not in the map.
MapCorrectionStats applyPoseGraphCorrection(
    map::Map& map, const std::map<map::KeyframeId, geometry::Sim3>& S_kf_world_corrected);

}  // namespace scale_drift_slam::loop
