#include "scale_drift_slam/tracking/tracking_map.h"

#include <algorithm>

#include "scale_drift_slam/map/map_update.h"

namespace scale_drift_slam::tracking {

void TrackingMap::addKeyframe(TrackedKeyframe keyframe) {
  const map::KeyframeId id = keyframe.id;
  for (const map::PointId point : keyframe.points)
    addObservation(id, point);
  keyframes_[id] = std::move(keyframe);
}

void TrackingMap::addObservation(map::KeyframeId keyframe, map::PointId point) {
  std::vector<map::KeyframeId>& observers = observers_[point];
  for (const map::KeyframeId other : observers) {
    if (other == keyframe) return;
  }
  for (const map::KeyframeId other : observers) {
    ++shared_[keyframe][other];
    ++shared_[other][keyframe];
  }
  observers.push_back(keyframe);
}

void TrackingMap::removePoint(map::PointId id) {
  points_.erase(id);
  const auto observers = observers_.find(id);
  if (observers == observers_.end()) return;
  for (const map::KeyframeId keyframe : observers->second) {
    const auto it = keyframes_.find(keyframe);
    if (it == keyframes_.end()) continue;
    std::vector<map::PointId>& points = it->second.points;
    points.erase(std::remove(points.begin(), points.end(), id), points.end());
  }
  forgetObservers(observers->second);
  observers_.erase(observers);
}

void TrackingMap::forgetObservers(const std::vector<map::KeyframeId>& observers) {
  for (std::size_t i = 0; i < observers.size(); ++i) {
    for (std::size_t j = i + 1; j < observers.size(); ++j) {
      unshare(observers[i], observers[j]);
      unshare(observers[j], observers[i]);
    }
  }
}

void TrackingMap::unshare(map::KeyframeId a, map::KeyframeId b) {
  const auto from_a = shared_.find(a);
  if (from_a == shared_.end()) return;
  const auto count = from_a->second.find(b);
  if (count == from_a->second.end()) return;
  if (--count->second <= 0) from_a->second.erase(count);
  if (from_a->second.empty()) shared_.erase(from_a);
}

void TrackingMap::cullKeyframe(map::KeyframeId id) {
  const auto it = keyframes_.find(id);
  if (it == keyframes_.end()) return;
  for (const map::PointId point : it->second.points) {
    const auto observers = observers_.find(point);
    if (observers == observers_.end()) continue;
    std::vector<map::KeyframeId>& by = observers->second;
    const auto self = std::find(by.begin(), by.end(), id);
    if (self == by.end()) continue;
    by.erase(self);
    for (const map::KeyframeId other : by) {
      unshare(id, other);
      unshare(other, id);
    }
  }
  it->second.points.clear();
  it->second.points.shrink_to_fit();
}

void TrackingMap::linkKeyframes(map::KeyframeId a, map::KeyframeId b) {
  std::vector<map::KeyframeId>& from_a = links_[a];
  if (std::find(from_a.begin(), from_a.end(), b) != from_a.end()) return;  // linked already
  from_a.push_back(b);
  links_[b].push_back(a);
}

void TrackingMap::addPoint(TrackedPoint point) {
  const map::PointId id = point.id;
  if (!point.appearance.compressed()) expanded_queue_.emplace_back(id, point.last_selected_frame);
  points_[id] = std::move(point);
}

void TrackingMap::linkPoint(map::KeyframeId keyframe, map::PointId point) {
  const auto it = keyframes_.find(keyframe);
  if (it == keyframes_.end()) return;
  it->second.points.push_back(point);
  addObservation(keyframe, point);
}

bool TrackingMap::apply(const map::MapUpdate& update) {
  if (update.map_version < version_) return false;
  version_ = update.map_version;
  map::moveKeyframesAndPoints(update, keyframes_, points_);
  for (const map::PointId id : update.removed_points)
    removePoint(id);
  for (const map::KeyframeId id : update.culled_keyframes)
    cullKeyframe(id);
  for (const auto& [a, b] : update.loop_links) {
    if (keyframes_.count(a) && keyframes_.count(b)) linkKeyframes(a, b);
  }
  return true;
}

std::optional<TrackingMap::TailCorrection> TrackingMap::tailCorrection(
    const map::MapUpdate& update) const {
  if (update.S_new_old || update.keyframe_poses.empty() || update.map_version < version_)
    return std::nullopt;
  const auto newest =
      std::max_element(update.keyframe_poses.begin(), update.keyframe_poses.end(),
                       [](const auto& a, const auto& b) { return a.first < b.first; });
  const auto anchor = keyframes_.find(newest->first);
  if (anchor == keyframes_.end() || std::next(anchor) == keyframes_.end()) return std::nullopt;
  // T_new^-1 T_old maps the old world coordinates near the anchor into the new ones.
  return TailCorrection{anchor->first, newest->second.inverse() * anchor->second.T_kf_world};
}

void TrackingMap::moveTail(const TailCorrection& tail) {
  const geometry::SE3 C_old_new = tail.C_new_old.inverse();
  const auto first_tail = keyframes_.upper_bound(tail.anchor);
  if (first_tail == keyframes_.end()) return;
  // The points made in the tail: the mapper has not seen them, no update places them (the others
  // it placed or left where they are).
  const map::PointId first_new = first_tail->second.first_new_point;
  std::unordered_set<map::PointId> moved;
  for (auto it = first_tail; it != keyframes_.end(); ++it) {
    it->second.T_kf_world = it->second.T_kf_world * C_old_new;
    for (const map::PointId id : it->second.points) {  // every point made there is linked to it
      const auto point = points_.find(id);
      if (id < first_new || point == points_.end() || !moved.insert(id).second) continue;
      point->second.p_world = tail.C_new_old * point->second.p_world;
    }
  }
}

std::unordered_set<map::KeyframeId> TrackingMap::neighbourhood(
    const std::vector<map::KeyframeId>& start, int steps, int min_shared) const {
  std::unordered_set<map::KeyframeId> reached(start.begin(), start.end());
  std::vector<map::KeyframeId> frontier = start;
  for (int step = 0; step < steps && !frontier.empty(); ++step) {
    std::vector<map::KeyframeId> next;
    const auto visit = [&](map::KeyframeId other) {
      if (reached.insert(other).second) next.push_back(other);
    };
    for (const map::KeyframeId id : frontier) {
      if (const auto shared = shared_.find(id); shared != shared_.end()) {
        for (const auto& [other, count] : shared->second) {
          if (count >= min_shared) visit(other);
        }
      }
      if (const auto links = links_.find(id); links != links_.end()) {
        for (const map::KeyframeId other : links->second)
          visit(other);
      }
    }
    frontier = std::move(next);
  }
  return reached;
}

std::size_t TrackingMap::compressIdlePatches(std::uint64_t frame, std::uint64_t idle_frames) {
  std::size_t compressed = 0;
  // Queued in frame order: stop at the first entry not due yet.
  while (!expanded_queue_.empty() && expanded_queue_.front().second + idle_frames <= frame) {
    const map::PointId id = expanded_queue_.front().first;
    expanded_queue_.pop_front();
    const auto it = points_.find(id);
    if (it == points_.end() || it->second.appearance.compressed()) continue;  // removed
    TrackedPoint& point = it->second;
    if (point.last_selected_frame + idle_frames > frame) {
      expanded_queue_.emplace_back(id, frame);  // still in use: look again later
      continue;
    }
    point.appearance.compress();
    ++compressed;
  }
  return compressed;
}

std::vector<map::PointId> TrackingMap::localPoints(const Eigen::Vector3d& camera_centre,
                                                   int num_recent, int num_nearest,
                                                   const std::vector<map::PointId>& tracked,
                                                   int min_shared, std::uint64_t frame) {
  std::vector<map::KeyframeId> chosen;
  for (auto it = keyframes_.rbegin();
       it != keyframes_.rend() && static_cast<int>(chosen.size()) < num_recent; ++it) {
    chosen.push_back(it->first);
  }
  // The tracked region: the newest keyframes and those observing the points just tracked.
  std::vector<map::KeyframeId> region = chosen;
  std::unordered_set<map::KeyframeId> in_region(region.begin(), region.end());
  for (const map::PointId point : tracked) {
    const auto observers = observers_.find(point);
    if (observers == observers_.end()) continue;
    for (const map::KeyframeId id : observers->second) {
      if (keyframes_.count(id) && in_region.insert(id).second) region.push_back(id);
    }
  }
  std::vector<std::pair<double, map::KeyframeId>> by_distance;
  for (const map::KeyframeId id : neighbourhood(region, 2, min_shared)) {
    const auto it = keyframes_.find(id);
    if (it == keyframes_.end() || it->second.points.empty()) continue;  // culled: no points
    by_distance.emplace_back(
        (it->second.T_kf_world.inverseTranslation() - camera_centre).squaredNorm(), id);
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
      if (it->second.appearance.compressed()) {
        it->second.appearance.expand();
        expanded_queue_.emplace_back(point_id, frame);
      }
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

std::vector<Eigen::Vector3d> TrackingMap::keyframeViewAxes() const {
  std::vector<Eigen::Vector3d> axes;
  axes.reserve(keyframes_.size());
  for (const auto& [id, keyframe] : keyframes_) {
    axes.push_back(keyframe.T_kf_world.rotation().conjugate() * Eigen::Vector3d::UnitZ());
  }
  return axes;
}

}  // namespace scale_drift_slam::tracking
