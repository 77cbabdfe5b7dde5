#include "scale_drift_slam/loop/map_correction.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace scale_drift_slam::loop {

MapCorrectionStats applyPoseGraphCorrection(
    map::Map& map, const std::map<map::KeyframeId, geometry::Sim3>& S_kf_world_corrected) {
  for (const auto& [id, S] : S_kf_world_corrected) {
    if (!map.hasKeyframe(id)) {
      throw std::invalid_argument("map correction: keyframe " + std::to_string(id) +
                                  " is not in the map");
    }
    if (!S.rotation().coeffs().allFinite() || !S.translation().allFinite() ||
        !std::isfinite(S.logScale())) {
      throw std::invalid_argument("map correction: the corrected pose of keyframe " +
                                  std::to_string(id) + " is not finite");
    }
  }
  MapCorrectionStats stats;
  // Points first: they need the reference keyframes' old poses.
  for (auto& [point_id, point] : map.points()) {
    const auto corrected = S_kf_world_corrected.find(point.reference_keyframe);
    if (corrected == S_kf_world_corrected.end()) {
      continue;
    }
    const geometry::SE3& T_ref_world_old = map.keyframe(point.reference_keyframe).T_kf_world;
    point.p_world = corrected->second.inverse() * (T_ref_world_old * point.p_world);
    ++stats.points_moved;
  }
  for (const auto& [id, S] : S_kf_world_corrected) {
    map.keyframe(id).T_kf_world = S.toSE3();
    ++stats.keyframes_corrected;
  }
  map.bumpVersion();
  return stats;
}

}  // namespace scale_drift_slam::loop
