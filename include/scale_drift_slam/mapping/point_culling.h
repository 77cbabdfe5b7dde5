#pragma once
// Culling of weak map points (issue 18, memory that grows with the map): a point that no
// keyframe observed again since the one that made it and that the camera has left behind (it
// lies behind the newest keyframe: forward driving passes most points within a few frames) helps
// neither the window BA (two views) nor relocalisation or loop verification much, and it costs
// the tracker its patches, the mapper and the loop closer their copies. ORB-SLAM culls points
// seen by fewer than three keyframes once two have passed; a point still in front of the camera
// is kept here: the tracker matches at most search.max_points points a frame, so a visible point
// may go unobserved for a while (culling those starved courtyard_loop at 5 Hz: 108 of 149
// frames tracked instead of 149).

#include <vector>

#include "scale_drift_slam/map/map.h"

namespace scale_drift_slam::mapping {

struct PointCullingParams {
  /// A point observed by fewer keyframes than this is culled... (0: no culling)
  int min_keyframes = 3;
  /// ...once this many keyframes came after its newest observation (the window BA's size: it no
  /// longer refines the point), if it then lies behind the newest keyframe.
  int after_keyframes = 10;
  /// Throws std::invalid_argument naming the first bad value.
  void validate() const;
};

/// The points to cull now, in increasing id order: those whose newest observation is in the
/// keyframe `after_keyframes` before the newest one in `map`, that fewer than `min_keyframes`
/// keyframes observe and that lie behind the newest keyframe. Called once per new keyframe, it
/// looks at every point exactly once (when its last observer reaches that age) and costs the
/// observations of one keyframe.
std::vector<map::PointId> weakPoints(const map::Map& map, const PointCullingParams& params);

}  // namespace scale_drift_slam::mapping
