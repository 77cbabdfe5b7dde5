#include "scale_drift_slam/loop/map_correction.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/Core>

namespace scale_drift_slam::loop {
namespace {

/// What the disturbance test needs of a keyframe, as matrices (one product per observation).
struct KeyframeTransforms {
  bool present = false;
  Eigen::Matrix3d R_new = Eigen::Matrix3d::Identity();  ///< T_k_new = [R_new, t_new].
  Eigen::Vector3d t_new = Eigen::Vector3d::Zero();
  Eigen::Matrix3d sR = Eigen::Matrix3d::Identity();  ///< C_k = [s R, t].
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  Eigen::Matrix3d sR_inverse = Eigen::Matrix3d::Identity();  ///< C_k^-1.
  Eigen::Vector3d t_inverse = Eigen::Vector3d::Zero();
};

/// Per keyframe id (ids are dense in maps the SLAM builds; a sparse map costs memory only).
std::vector<KeyframeTransforms> keyframeTransforms(
    const map::Map& map,
    const std::vector<std::pair<map::KeyframeId, geometry::Sim3>>& corrections) {
  std::vector<KeyframeTransforms> table(
      map.keyframes().empty() ? 0 : std::size_t{map.keyframes().rbegin()->first} + 1);
  for (const auto& [id, keyframe] : map.keyframes()) {
    KeyframeTransforms& k = table[id];
    k.present = true;
    k.R_new = keyframe.T_kf_world.rotationMatrix();
    k.t_new = keyframe.T_kf_world.translation();
  }
  for (const auto& [id, C] : corrections) {
    if (id >= table.size() || !table[id].present) continue;
    KeyframeTransforms& k = table[id];
    k.sR = C.scale() * C.rotation().toRotationMatrix();
    k.t = C.translation();
    const geometry::Sim3 inverse = C.inverse();
    k.sR_inverse = inverse.scale() * inverse.rotation().toRotationMatrix();
    k.t_inverse = inverse.translation();
  }
  return table;
}

/// Whether the point's image in some observer moved by more than `min_shift` (normalised units).
bool disturbed(const map::MapPoint& point, const std::vector<KeyframeTransforms>& table,
               double min_shift) {
  // A point whose reference keyframe is not in the map was not moved (C_r = identity).
  const bool anchored =
      point.reference_keyframe < table.size() && table[point.reference_keyframe].present;
  const Eigen::Vector3d x_new = point.p_world;
  const Eigen::Vector3d x_old =
      anchored ? Eigen::Vector3d(table[point.reference_keyframe].sR_inverse * x_new +
                                 table[point.reference_keyframe].t_inverse)
               : x_new;
  const double limit = min_shift * min_shift;
  for (const map::KeyframeId id : point.observed_by) {
    if (id == point.reference_keyframe || id >= table.size() || !table[id].present) continue;
    const KeyframeTransforms& k = table[id];
    const Eigen::Vector3d now = k.R_new * x_new + k.t_new;
    const Eigen::Vector3d before = k.R_new * (k.sR * x_old + k.t) + k.t_new;
    if (!(now.z() > 0.0) || !(before.z() > 0.0)) return true;
    if ((now.head<2>() / now.z() - before.head<2>() / before.z()).squaredNorm() > limit)
      return true;
  }
  return false;
}

}  // namespace

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

std::vector<map::PointId> pointsDisturbedByCorrection(
    const map::Map& corrected,
    const std::vector<std::pair<map::KeyframeId, geometry::Sim3>>& corrections,
    double focal_length_px, double min_shift_px) {
  if (!(std::isfinite(focal_length_px) && focal_length_px > 0.0) ||
      !(std::isfinite(min_shift_px) && min_shift_px >= 0.0)) {
    throw std::invalid_argument(
        "disturbed points: the focal length must be finite and > 0, the shift finite and >= 0");
  }
  const std::vector<KeyframeTransforms> table = keyframeTransforms(corrected, corrections);
  const double min_shift = min_shift_px / focal_length_px;
  std::vector<map::PointId> ids;
  for (const auto& [id, point] : corrected.points()) {
    if (disturbed(point, table, min_shift)) ids.push_back(id);
  }
  std::sort(ids.begin(), ids.end());
  return ids;
}

}  // namespace scale_drift_slam::loop
