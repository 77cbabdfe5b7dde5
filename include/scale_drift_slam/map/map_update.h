#pragma once
// Consumers of the mapper's corrections (map::MapUpdate): applying one to a copy of the map (the
// loop closer keeps one), correcting a pose by a loop correction, and bringing a keyframe message
// that was made before a loop correction into the corrected world frame.
//
// Why the last one: the tracker keeps running while the mapper closes a loop. A keyframe it drops
// before it has applied the correction is in the old world frame; its receivers (mapper, loop
// closer) know which corrections came after its map_version and apply them (CorrectionHistory).

#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/geometry/sim3.h"
#include "scale_drift_slam/map/keyframe_message.h"
#include "scale_drift_slam/map/map.h"

namespace scale_drift_slam::map {

/// The pose of a camera after the world moved by p_new = S_new_old p_old: T_new = T_old S^-1 as a
/// similarity, taken back to a rigid pose (rotation kept, translation t / s): the camera centre
/// moves with the world, the camera keeps its orientation relative to it.
geometry::SE3 correctPose(const geometry::SE3& T_cam_world, const geometry::Sim3& S_new_old);

/// Adds what a keyframe message brings to a map: its new points (those not there yet), the
/// keyframe with its observations of points the map holds (others are skipped), and the new
/// points' observations in earlier keyframes the map holds. Throws std::invalid_argument when the
/// keyframe is already in the map.
void addKeyframeMessage(const KeyframeMessage& message, Map& map);

/// Moves keyframes and points as `update` says: the loop correction S_new_old (if any) on every
/// one, then the listed poses and positions (ids not held are skipped). Shared by the global map
/// (applyMapUpdate) and the tracker's copy (tracking::TrackingMap::apply): `keyframes` and
/// `points` map ids to objects with a `T_kf_world` and a `p_world`.
template <typename KeyframesById, typename PointsById>
void moveKeyframesAndPoints(const MapUpdate& update, KeyframesById& keyframes, PointsById& points) {
  if (update.S_new_old) {
    for (auto& entry : keyframes)
      entry.second.T_kf_world = correctPose(entry.second.T_kf_world, *update.S_new_old);
    for (auto& entry : points)
      entry.second.p_world = *update.S_new_old * entry.second.p_world;
  }
  for (const auto& [id, T_kf_world] : update.keyframe_poses) {
    const auto it = keyframes.find(id);
    if (it != keyframes.end()) it->second.T_kf_world = T_kf_world;
  }
  for (const auto& [id, p_world] : update.point_positions) {
    const auto it = points.find(id);
    if (it != points.end()) it->second.p_world = p_world;
  }
}

/// Applies `update` to `map`: the loop correction S_new_old (if any) to every keyframe and point,
/// then the listed poses and positions of known ids, then the removals. Updates whose version is
/// below `*applied_version` are ignored (returns false); otherwise *applied_version becomes the
/// update's version.
bool applyMapUpdate(const MapUpdate& update, Map& map, std::uint64_t* applied_version);

/// The loop corrections seen so far, by the map version that introduced them.
class CorrectionHistory {
 public:
  /// Remembers the update if it is a loop correction.
  void record(const MapUpdate& update);
  /// The similarity taking world coordinates of a message made at `version` (the version of the
  /// last update its sender had applied) into the current frame; nullopt when none is due.
  std::optional<geometry::Sim3> correctionSince(std::uint64_t version) const;
  /// Moves a keyframe message made before a loop correction into the corrected world frame (pose
  /// and new points; observations are image measurements and stay). Returns true when it moved.
  bool bringUpToDate(KeyframeMessage& message) const;
  std::size_t size() const { return corrections_.size(); }

 private:
  std::vector<std::pair<std::uint64_t, geometry::Sim3>> corrections_;  ///< In version order.
};

}  // namespace scale_drift_slam::map
