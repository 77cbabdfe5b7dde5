#pragma once
// Applies a solved pose graph to the map (doc/algorithm.md, "Loop closure correction"):
//   points:    x' = (S_r^new)^-1 (T_r^old x), r = the point's reference keyframe (the point keeps
//              its coordinates in that keyframe and moves with it, scale included);
//   keyframes: T' = S^new as a rigid pose: rotation kept, translation t / s (same camera centre).
// Keyframes without a corrected pose, and points whose reference keyframe has none, are left
// unchanged.

#include <cstddef>
#include <map>
#include <utility>
#include <vector>

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

/// The points of a corrected map that the correction disturbed: those whose image in one of their
/// observers it moved by more than `min_shift_px` pixels (focal length `focal_length_px`). A
/// point moves with its reference keyframe r, x_new = C_r x_old, where C_k = S_k_new^-1 T_k_old
/// is keyframe k's correction (old world -> new world; MapUpdate::keyframe_corrections). In an
/// observer k it is then seen at pi(T_k_new x_new) against pi(T_k_new C_k C_r^-1 x_new) before
/// (the same as pi(T_k_old x_old): S_k_new and its rigid pose T_k_new project alike): the two
/// differ only where the correction is not the same similarity for r and k, i.e. where it is not
/// smooth (near the loop's ends, across the loop edge), and there a structure-only BA has work to
/// do; elsewhere a point keeps the reprojection errors it had before the correction, to within
/// `min_shift_px`. A keyframe without a correction counts as not moved (C = identity); a point
/// seen behind an observer before or after counts as disturbed. Sorted by id.
std::vector<map::PointId> pointsDisturbedByCorrection(
    const map::Map& corrected,
    const std::vector<std::pair<map::KeyframeId, geometry::Sim3>>& corrections,
    double focal_length_px, double min_shift_px);

}  // namespace scale_drift_slam::loop
