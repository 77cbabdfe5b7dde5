#pragma once
// Culling of redundant keyframes (issue 18, memory that grows with the map; the paper's keyframe
// rule keeps keyframes by distance, and forward driving makes one every few frames): a keyframe
// whose points are nearly all seen by enough other keyframes adds little but costs its
// observations in every map copy, its place-recognition entry and its stored image. ORB-SLAM's
// criterion is 90 % of its points seen by at least 3 other keyframes; here 2: the weak-point
// culling (point_culling.h) already drops the points seen by fewer than 3 keyframes, and with 3
// only 2 of 249 keyframes were culled on the first 600 frames of city_tour (with 2: 279 of 600
// on the first 1500, at a lower ATE).
//
// A culled keyframe loses its observations (and the loop closer its image and place) but keeps
// its pose: it stays a vertex of the pose graph, the anchor of the points and trajectory frames
// referenced to it, and a place the tracker's keyframe rule knows was mapped. The map updates
// carry culled ids (map::MapUpdate::culled_keyframes) to the tracker and the loop closer.

#include <optional>
#include <unordered_set>

#include "scale_drift_slam/map/map.h"

namespace scale_drift_slam::mapping {

struct KeyframeCullingParams {
  /// A keyframe is redundant when at least this share of its points... (0: no culling)
  double redundant_ratio = 0.9;
  /// ...is seen by at least this many other keyframes.
  int min_other_observers = 2;
  /// Throws std::invalid_argument naming the first bad value.
  void validate() const;
};

/// The keyframe to cull now, if any: the newest one with `window_size` keyframes after it (it has
/// just left the window BA, whose keyframes are never culled), when it is redundant, holds
/// observations, is not the oldest keyframe (the world's anchor) and is not in `keep` (the ends
/// of loop edges). One keyframe is examined per call, at the cost of its observations.
std::optional<map::KeyframeId> redundantKeyframe(const map::Map& map, int window_size,
                                                 const KeyframeCullingParams& params,
                                                 const std::unordered_set<map::KeyframeId>& keep);

}  // namespace scale_drift_slam::mapping
