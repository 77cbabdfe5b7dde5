#pragma once
// Culling of weak map points (issue 18, memory that grows with the map): a point that no
// keyframe observed again since the one that made it is, a few keyframes later, either behind
// the camera (forward driving passes most points in a few frames) or was a poor match. It helps
// neither the window BA (two views) nor relocalisation or loop verification much, and it costs
// the tracker its patches, the mapper and the loop closer their copies. ORB-SLAM culls such
// points the same way (observed by fewer than three keyframes, once two have passed).

#include <vector>

#include "scale_drift_slam/map/map.h"

namespace scale_drift_slam::mapping {

struct PointCullingParams {
  /// A point observed by fewer keyframes than this is culled... (0: no culling)
  int min_keyframes = 3;
  /// ...once this many keyframes came after its newest observation.
  int after_keyframes = 3;
  /// Throws std::invalid_argument naming the first bad value.
  void validate() const;
};

/// The points to cull now, in increasing id order: those whose newest observation is in the
/// keyframe `after_keyframes` before the newest one in `map` and that fewer than `min_keyframes`
/// keyframes observe. Called once per new keyframe, it looks at every point exactly once (when
/// its last observer reaches that age) and costs the observations of one keyframe.
std::vector<map::PointId> weakPoints(const map::Map& map, const PointCullingParams& params);

}  // namespace scale_drift_slam::mapping
