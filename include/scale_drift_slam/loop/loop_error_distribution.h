#pragma once
// The initial guess of the pose-graph optimisation (loop/pose_graph.h): each loop edge's error
// spread along the odometry between its two ends, so that Ceres' Levenberg-Marquardt starts next
// to the optimum instead of at the open loop.
//
// A spanning forest of the graph is rooted at the fixed vertices and prefers consecutive edges,
// then co-visibility edges; a loop edge outside it (a chord) closes one cycle. The forest's edge
// residuals r_e parametrise the free poses exactly (compose from the roots). For one chord
// c = (a -> b), a world-frame perturbation X <- X exp(eps) of the poses changes
//   r_c by  Jl(r_c)^-1 Adj(M_c X_b) (eps_b - eps_a),
// and a forest edge e changes eps across it (child minus parent) by
//   s_e Adj(M_e X_to)^-1 Jl(r_e) d_e   for a change d_e of r_e (s_e = +1 if the child is e's 'to').
// Summed along the forest path from a to b this gives r_c' = r_c + sum_e G_ce d_e. Minimising
// sum_e d_e^T Lambda_e d_e + sum_c r_c'^T Lambda_c r_c' (the chi2 of the cycles, linearised, the
// forest edges' residuals at the given poses taken as their rest state) gives
//   d_e = -Lambda_e^-1 sum_c G_ce^T mu_c,  (Lambda_c^-1 delta_cc' + A_cc') mu_c' = r_c,
//   A_cc' = sum_{e on both paths} G_ce Lambda_e^-1 G_c'e^T,
// i.e. each loop's error shared out along its path in proportion to the edges' covariances, loops
// that share edges solved together (a dense system of 7 x loops unknowns; one loop: mu =
// Lambda_c (I + A Lambda_c)^-1 r_c). The poses are then composed from the roots with the new
// residuals. Co-visibility chords are left to the optimiser. A further pass re-linearises at the
// new poses, the rest state kept (a Gauss-Newton step in the cycles' coordinates: the forest
// edges' chi2 is exactly quadratic in their residuals, the chords carry the nonlinearity). The
// guess is kept only if it lowers chi2, and skipped when its work (passes x (paths + loop pairs
// on shared edges + vertices)) would exceed about four LM iterations' worth.
//
// It is a starting point, not a solver: a fixed number of passes, no convergence test; Ceres
// still iterates to its own tolerances (on the Keble loop 3 passes leave chi2 ~1e-4 relative
// above the optimum and Ceres takes 3 (Sim(3)) or 4 (SE(3)) iterations from there; two
// overlapping loops on a synthetic circle: 2 passes reach the optimum's chi2 to 4 digits).

#include <vector>

#include "scale_drift_slam/geometry/sim3.h"
#include "scale_drift_slam/loop/pose_graph.h"

namespace scale_drift_slam::loop {

struct LoopErrorDistribution {
  /// Every vertex in the order of PoseGraph::vertices() (ids ascending), fixed ones unchanged;
  /// in SE(3) mode with scale 1. Empty when the guess is not used (no loop chord, or no lower
  /// chi2 than the given poses).
  std::vector<geometry::Sim3> S_kf_world;
  int loops = 0;            ///< Loop edges whose error was distributed.
  double given_chi2 = 0.0;  ///< chi2 of the graph's vertices (in the given mode) ...
  double chi2 = 0.0;        ///< ... and of the guess (given_chi2 when it is not used).
};

/// The guess for the graph in the given mode after `passes` (>= 1, else std::invalid_argument)
/// passes over the loops. The graph must pass PoseGraph::optimize()'s checks (a fixed vertex,
/// every vertex connected to a fixed one).
LoopErrorDistribution distributeLoopErrors(const PoseGraph& graph, PoseGraphMode mode, int passes);

}  // namespace scale_drift_slam::loop
