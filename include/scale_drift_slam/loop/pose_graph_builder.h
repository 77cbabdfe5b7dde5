#pragma once
// Builds the loop-closure pose graph from the keyframe map (doc/algorithm.md, "Loop closure
// correction"): every keyframe pose T_i becomes a similarity with s = 1; consecutive and
// co-visible keyframes are joined by relative constraints S_ij = S_i S_j^-1 computed from the
// current estimates (scale 1); the loop edges, with their measured scales, come from loop
// detection and are added as given.

#include <vector>

#include "scale_drift_slam/loop/pose_graph.h"
#include "scale_drift_slam/map/map.h"

namespace scale_drift_slam::loop {

struct PoseGraphBuilderOptions {
  /// Join each keyframe to the previous one (in id order among the selected keyframes).
  bool consecutive_edges = true;
  /// Join non-consecutive keyframes that observe at least this many common points; 0 adds no
  /// co-visibility edges.
  int min_shared_points = 0;
  /// At most this many co-visibility edges from each keyframe to older ones, the strongest
  /// (most shared points) first; 0: no limit. Bounds the graph's size and its fill-in.
  int max_covisibility_edges_per_keyframe = 0;
  /// Information of the edges built here (identity as in the paper's Keble experiment).
  Matrix7d information = Matrix7d::Identity();

  /// Throws std::invalid_argument naming the offending field.
  void validate() const;
};

/// A pose graph over `keyframes` (all keyframes of the map when empty) with the built edges plus
/// `loop_edges`, and the vertices in `fixed` held constant. Each built edge goes from the newer
/// keyframe i to the older j with S_ij = T_i T_j^-1, as the authors' implementation does.
/// Throws std::invalid_argument for an unknown keyframe, a loop edge outside the selection or a
/// fixed id outside the selection (and for anything PoseGraph::addEdge refuses).
PoseGraph buildPoseGraph(const map::Map& map, const std::vector<map::KeyframeId>& keyframes,
                         const std::vector<PoseGraphEdge>& loop_edges,
                         const std::vector<map::KeyframeId>& fixed,
                         const PoseGraphBuilderOptions& options);

}  // namespace scale_drift_slam::loop
