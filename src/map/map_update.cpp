#include "scale_drift_slam/map/map_update.h"

namespace scale_drift_slam::map {

geometry::SE3 correctPose(const geometry::SE3& T_cam_world, const geometry::Sim3& S_new_old) {
  return (geometry::Sim3(T_cam_world) * S_new_old.inverse()).toSE3();
}

void addKeyframeMessage(const KeyframeMessage& message, Map& map) {
  for (const NewMapPoint& point : message.new_points) {
    if (!map.hasPoint(point.id))
      map.addPoint({point.id, point.p_world, point.reference_keyframe, {}});
  }
  Keyframe keyframe = message.keyframe;
  keyframe.observations.clear();
  for (const Observation& observation : message.keyframe.observations) {
    if (map.hasPoint(observation.point_id)) keyframe.observations.push_back(observation);
  }
  map.addKeyframe(std::move(keyframe));
  for (const KeyframeObservation& o : message.earlier_observations) {
    if (map.hasKeyframe(o.keyframe_id) && map.hasPoint(o.point_id)) {
      map.addObservation(o.keyframe_id, o.point_id, o.xy);
    }
  }
}

bool applyMapUpdate(const MapUpdate& update, Map& map, std::uint64_t* applied_version) {
  if (applied_version) {
    if (update.map_version < *applied_version) return false;
    *applied_version = update.map_version;
  }
  moveKeyframesAndPoints(update, map.keyframes(), map.points());
  for (const PointId id : update.removed_points)
    map.removePoint(id);
  for (const KeyframeId id : update.culled_keyframes)
    map.clearObservations(id);
  map.bumpVersion();
  return true;
}

void CorrectionHistory::record(const MapUpdate& update) {
  if (update.S_new_old) corrections_.emplace_back(update.map_version, *update.S_new_old);
}

std::optional<geometry::Sim3> CorrectionHistory::correctionSince(std::uint64_t version) const {
  std::optional<geometry::Sim3> S;
  for (const auto& [correction_version, S_new_old] : corrections_) {
    if (correction_version <= version) continue;
    S = S ? S_new_old * *S : S_new_old;
  }
  return S;
}

bool CorrectionHistory::bringUpToDate(KeyframeMessage& message) const {
  const std::optional<geometry::Sim3> S = correctionSince(message.map_version);
  if (!S) return false;
  message.keyframe.T_kf_world = correctPose(message.keyframe.T_kf_world, *S);
  for (NewMapPoint& point : message.new_points)
    point.p_world = *S * point.p_world;
  message.map_version = corrections_.back().first;
  return true;
}

}  // namespace scale_drift_slam::map
