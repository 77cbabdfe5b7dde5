#include "scale_drift_slam/map/map.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace scale_drift_slam::map {

Keyframe& Map::addKeyframe(Keyframe keyframe) {
  const KeyframeId id = keyframe.id;
  if (hasKeyframe(id)) {
    throw std::invalid_argument("keyframe " + std::to_string(id) + " is already in the map");
  }
  for (const Observation& observation : keyframe.observations) {
    if (!hasPoint(observation.point_id)) {
      throw std::invalid_argument("keyframe " + std::to_string(id) + " observes unknown point " +
                                  std::to_string(observation.point_id));
    }
  }
  for (const Observation& observation : keyframe.observations) {
    points_.at(observation.point_id).observed_by.push_back(id);
  }
  num_observations_ += keyframe.observations.size();
  ++version_;
  return keyframes_.emplace(id, std::move(keyframe)).first->second;
}

MapPoint& Map::addPoint(MapPoint point) {
  if (hasPoint(point.id)) {
    throw std::invalid_argument("point " + std::to_string(point.id) + " is already in the map");
  }
  if (!point.p_world.allFinite()) {
    throw std::invalid_argument("point " + std::to_string(point.id) + " has a non-finite position");
  }
  ++version_;
  const PointId id = point.id;
  return points_.emplace(id, std::move(point)).first->second;
}

void Map::addObservation(KeyframeId keyframe_id, PointId point_id, const Eigen::Vector2d& xy) {
  if (!hasKeyframe(keyframe_id)) {
    throw std::invalid_argument("observation in unknown keyframe " + std::to_string(keyframe_id));
  }
  if (!hasPoint(point_id)) {
    throw std::invalid_argument("observation of unknown point " + std::to_string(point_id));
  }
  // A keyframe gains observations over the next keyframes (points promoted later): grown by a
  // quarter, not doubled, so that the spare capacity of thousands of keyframes stays small.
  std::vector<Observation>& observations = keyframes_.at(keyframe_id).observations;
  if (observations.size() == observations.capacity())
    observations.reserve(observations.size() + observations.size() / 4 + 4);
  observations.push_back({point_id, xy});
  points_.at(point_id).observed_by.push_back(keyframe_id);
  ++num_observations_;
  ++version_;
}

std::vector<PointId> Map::clearObservations(KeyframeId id) {
  std::vector<PointId> observed;
  const auto it = keyframes_.find(id);
  if (it == keyframes_.end()) return observed;
  for (const Observation& observation : it->second.observations) {
    std::vector<KeyframeId>& by = points_.at(observation.point_id).observed_by;
    by.erase(std::remove(by.begin(), by.end(), id), by.end());
    observed.push_back(observation.point_id);
  }
  num_observations_ -= it->second.observations.size();
  it->second.observations.clear();
  it->second.observations.shrink_to_fit();
  std::sort(observed.begin(), observed.end());
  observed.erase(std::unique(observed.begin(), observed.end()), observed.end());
  ++version_;
  return observed;
}

void Map::removePoint(PointId id) {
  const auto it = points_.find(id);
  if (it == points_.end()) return;
  for (const KeyframeId keyframe_id : it->second.observed_by) {
    std::vector<Observation>& observations = keyframes_.at(keyframe_id).observations;
    const auto end = std::remove_if(observations.begin(), observations.end(),
                                    [id](const Observation& o) { return o.point_id == id; });
    num_observations_ -= static_cast<std::size_t>(observations.end() - end);
    observations.erase(end, observations.end());
  }
  points_.erase(it);
  ++version_;
}

const Keyframe& Map::keyframe(KeyframeId id) const {
  const auto it = keyframes_.find(id);
  if (it == keyframes_.end()) throw std::out_of_range("no keyframe " + std::to_string(id));
  return it->second;
}

Keyframe& Map::keyframe(KeyframeId id) {
  return const_cast<Keyframe&>(static_cast<const Map&>(*this).keyframe(id));
}

const MapPoint& Map::point(PointId id) const {
  const auto it = points_.find(id);
  if (it == points_.end()) throw std::out_of_range("no point " + std::to_string(id));
  return it->second;
}

MapPoint& Map::point(PointId id) {
  return const_cast<MapPoint&>(static_cast<const Map&>(*this).point(id));
}

}  // namespace scale_drift_slam::map
