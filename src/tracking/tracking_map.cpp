#include "scale_drift_slam/tracking/tracking_map.h"

#include <algorithm>

namespace scale_drift_slam::tracking {

void TrackingMap::addKeyframe(TrackedKeyframe keyframe) {
  const map::KeyframeId id = keyframe.id;
  keyframes_[id] = std::move(keyframe);
}

void TrackingMap::addPoint(TrackedPoint point) {
  const map::PointId id = point.id;
  points_[id] = std::move(point);
}

void TrackingMap::linkPoint(map::KeyframeId keyframe, map::PointId point) {
  const auto it = keyframes_.find(keyframe);
  if (it != keyframes_.end()) it->second.points.push_back(point);
}

bool TrackingMap::apply(const map::MapUpdate& update) {
  if (update.map_version < version_) return false;
  version_ = update.map_version;
  if (update.S_new_old) {
    const geometry::Sim3& S = *update.S_new_old;
    const geometry::Sim3 S_inv = S.inverse();
    for (auto& [id, keyframe] : keyframes_) {
      // T_kf_new = T_kf_old S^-1 as a similarity; its rigid part keeps the camera centre.
      keyframe.T_kf_world = (geometry::Sim3(keyframe.T_kf_world) * S_inv).toSE3();
    }
    for (auto& [id, point] : points_)
      point.p_world = S * point.p_world;
  }
  for (const auto& [id, T_kf_world] : update.keyframe_poses) {
    const auto it = keyframes_.find(id);
    if (it != keyframes_.end()) it->second.T_kf_world = T_kf_world;
  }
  for (const auto& [id, p_world] : update.point_positions) {
    const auto it = points_.find(id);
    if (it != points_.end()) it->second.p_world = p_world;
  }
  for (const map::PointId id : update.removed_points)
    points_.erase(id);
  return true;
}

std::vector<map::PointId> TrackingMap::localPoints(const Eigen::Vector3d& camera_centre,
                                                   int num_recent, int num_nearest,
                                                   std::uint64_t frame) {
  std::vector<map::KeyframeId> chosen;
  for (auto it = keyframes_.rbegin();
       it != keyframes_.rend() && static_cast<int>(chosen.size()) < num_recent; ++it) {
    chosen.push_back(it->first);
  }
  std::vector<std::pair<double, map::KeyframeId>> by_distance;
  for (const auto& [id, keyframe] : keyframes_) {
    by_distance.emplace_back(
        (keyframe.T_kf_world.inverseTranslation() - camera_centre).squaredNorm(), id);
  }
  const std::size_t n = std::min<std::size_t>(num_nearest, by_distance.size());
  std::partial_sort(by_distance.begin(), by_distance.begin() + n, by_distance.end());
  for (std::size_t i = 0; i < n; ++i)
    chosen.push_back(by_distance[i].second);

  std::vector<map::PointId> selected;
  for (const map::KeyframeId id : chosen) {
    for (const map::PointId point_id : keyframes_.at(id).points) {
      const auto it = points_.find(point_id);
      if (it == points_.end() || it->second.last_selected_frame == frame) continue;
      it->second.last_selected_frame = frame;
      selected.push_back(point_id);
    }
  }
  return selected;
}

std::vector<std::pair<map::KeyframeId, Eigen::Vector3d>> TrackingMap::keyframeCentres() const {
  std::vector<std::pair<map::KeyframeId, Eigen::Vector3d>> centres;
  centres.reserve(keyframes_.size());
  for (const auto& [id, keyframe] : keyframes_) {
    centres.emplace_back(id, keyframe.T_kf_world.inverseTranslation());
  }
  return centres;
}

}  // namespace scale_drift_slam::tracking
