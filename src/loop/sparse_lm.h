#pragma once
// Internal to the loop module: the pose graph's own Levenberg-Marquardt (PoseGraphSolver::
// kSparseLM). Same residuals, Jacobians, damping and step control as the Ceres path, but the
// normal equations are assembled directly in 6x6 / 7x7 blocks into a fixed sparsity pattern and
// factorised by CHOLMOD (SuiteSparse) through Eigen, which removes Ceres' per-iteration
// bookkeeping (it dominates on graphs of a few thousand parameters).

#include <map>
#include <vector>

#include "scale_drift_slam/loop/pose_graph.h"

namespace scale_drift_slam::loop {

/// Solves the graph; the vertices and edges are valid (PoseGraph checked them) and the gauge is
/// fixed. Throws std::runtime_error when the linear system cannot be factorised at any damping.
PoseGraphResult optimizeWithSparseLM(const std::map<map::KeyframeId, PoseGraphVertex>& vertices,
                                     const std::vector<PoseGraphEdge>& edges,
                                     const PoseGraphOptions& options);

}  // namespace scale_drift_slam::loop
