#include "scale_drift_slam/loop/map_correction.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include <Eigen/Core>

namespace scale_drift_slam::loop {
namespace {

/// A value per keyframe id: a plain vector when the ids are dense (as in the SLAM's maps: passes
/// over 10^5 scattered points must not search a tree per point), a hash map otherwise.
template <typename T>
class ByKeyframe {
 public:
  ByKeyframe(map::KeyframeId largest, std::size_t count)
      : dense_(std::size_t{largest} < 4 * count + 1024) {
    if (dense_) values_.resize(std::size_t{largest} + 1);
  }
  T& insert(map::KeyframeId id) {
    std::pair<bool, T>& slot = dense_ ? values_[id] : sparse_[id];
    slot.first = true;
    return slot.second;
  }
  const T* find(map::KeyframeId id) const {
    if (dense_) {
      return id < values_.size() && values_[id].first ? &values_[id].second : nullptr;
    }
    const auto it = sparse_.find(id);
    return it == sparse_.end() ? nullptr : &it->second.second;
  }
  T* findMutable(map::KeyframeId id) { return const_cast<T*>(find(id)); }

 private:
  bool dense_;
  std::vector<std::pair<bool, T>> values_;
  std::unordered_map<map::KeyframeId, std::pair<bool, T>> sparse_;
};

/// What the disturbance test needs of a keyframe, as matrices (one product per observation).
struct KeyframeTransforms {
  Eigen::Matrix3d R_new = Eigen::Matrix3d::Identity();  ///< T_k_new = [R_new, t_new].
  Eigen::Vector3d t_new = Eigen::Vector3d::Zero();
  Eigen::Matrix3d sR = Eigen::Matrix3d::Identity();  ///< C_k = [s R, t].
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  Eigen::Matrix3d sR_inverse = Eigen::Matrix3d::Identity();  ///< C_k^-1.
  Eigen::Vector3d t_inverse = Eigen::Vector3d::Zero();
};

ByKeyframe<KeyframeTransforms> keyframeTransforms(
    const map::Map& map,
    const std::vector<std::pair<map::KeyframeId, geometry::Sim3>>& corrections) {
  ByKeyframe<KeyframeTransforms> table(
      map.keyframes().empty() ? 0 : map.keyframes().rbegin()->first, map.numKeyframes());
  for (const auto& [id, keyframe] : map.keyframes()) {
    KeyframeTransforms& k = table.insert(id);
    k.R_new = keyframe.T_kf_world.rotationMatrix();
    k.t_new = keyframe.T_kf_world.translation();
  }
  for (const auto& [id, C] : corrections) {
    KeyframeTransforms* k = table.findMutable(id);
    if (!k) continue;
    k->sR = C.scale() * C.rotation().toRotationMatrix();
    k->t = C.translation();
    const geometry::Sim3 inverse = C.inverse();
    k->sR_inverse = inverse.scale() * inverse.rotation().toRotationMatrix();
    k->t_inverse = inverse.translation();
  }
  return table;
}

/// Whether the point's image in some observer moved by more than `min_shift` (normalised units).
bool disturbed(const map::MapPoint& point, const ByKeyframe<KeyframeTransforms>& table,
               double min_shift) {
  // A point whose reference keyframe is not in the map was not moved (C_r = identity).
  const KeyframeTransforms* r = table.find(point.reference_keyframe);
  const Eigen::Vector3d x_new = point.p_world;
  const Eigen::Vector3d x_old = r ? Eigen::Vector3d(r->sR_inverse * x_new + r->t_inverse) : x_new;
  const double limit = min_shift * min_shift;
  for (const map::KeyframeId id : point.observed_by) {
    const KeyframeTransforms* k = id == point.reference_keyframe ? nullptr : table.find(id);
    if (!k) continue;
    const Eigen::Vector3d now = k->R_new * x_new + k->t_new;
    const Eigen::Vector3d before = k->R_new * (k->sR * x_old + k->t) + k->t_new;
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
  // Points first: they need the reference keyframes' old poses. x' = A_r x + b_r with
  // [A_r, b_r] = S_r_new^-1 T_r_old, computed once per keyframe.
  ByKeyframe<Eigen::Matrix<double, 3, 4>> moves(
      S_kf_world_corrected.empty() ? 0 : S_kf_world_corrected.rbegin()->first,
      S_kf_world_corrected.size());
  for (const auto& [id, S] : S_kf_world_corrected) {
    const geometry::Sim3 M = S.inverse() * geometry::Sim3(map.keyframe(id).T_kf_world);
    Eigen::Matrix<double, 3, 4>& move = moves.insert(id);
    move.leftCols<3>() = M.scale() * M.rotation().toRotationMatrix();
    move.col(3) = M.translation();
  }
  for (auto& [point_id, point] : map.points()) {
    const Eigen::Matrix<double, 3, 4>* move = moves.find(point.reference_keyframe);
    if (!move) {
      continue;
    }
    point.p_world = move->leftCols<3>() * point.p_world + move->col(3);
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
  const ByKeyframe<KeyframeTransforms> table = keyframeTransforms(corrected, corrections);
  const double min_shift = min_shift_px / focal_length_px;
  std::vector<map::PointId> ids;
  for (const auto& [id, point] : corrected.points()) {
    if (disturbed(point, table, min_shift)) ids.push_back(id);
  }
  std::sort(ids.begin(), ids.end());
  return ids;
}

}  // namespace scale_drift_slam::loop
