#pragma once
// The Ceres pieces of the pose graph (loop/pose_graph.h): one edge cost and one vertex manifold
// per mode, with analytic or automatic derivatives. Public so that the tests can check the
// Jacobians against numeric differentiation; PoseGraph::optimize() is the normal user.
//
// Parameter blocks: Sim(3) qx qy qz qw tx ty tz sigma (Sim3::toData), SE(3) qx qy qz qw tx ty tz.
// Vertex update: x <- exp(delta) x (left-multiplied), delta in R^7 (R^6 for SE(3)).
//
// Analytic Jacobians (doc/algorithm.md, "Loop closure correction"): with E = S_ij S_j S_i^-1 and
// r = log(E), left perturbations give E(d) = exp(Adj(S_ij) d_j - Adj(E) d_i) E to first order,
// hence  dr/dd_j = Jl(r)^-1 Adj(S_ij)  and  dr/dd_i = -Jl(r)^-1 Adj(E)  (geometry/lie_jacobians.h).
// They are handed to Ceres with the "lift" trick: the cost writes dr/d delta into the first
// TangentSize columns of the ambient Jacobian block (the rest zero) and the analytic manifold's
// PlusJacobian is [I; 0], so Ceres' product ambient * PlusJacobian is exactly dr/d delta. The
// autodiff cost differentiates w.r.t. the ambient parameters and pairs with the manifold whose
// PlusJacobian is the true d Plus(x, delta) / d delta.

#include <memory>

#include <ceres/cost_function.h>
#include <ceres/manifold.h>

#include "scale_drift_slam/loop/pose_graph.h"

namespace scale_drift_slam::loop {

/// The cost of one edge in the given mode: residual L^T r with Lambda = L L^T (so that Ceres'
/// 0.5 |L^T r|^2 is half the edge's chi2). Parameter blocks: (from, to). Throws
/// std::invalid_argument for an information matrix that is not symmetric positive definite.
std::unique_ptr<ceres::CostFunction> makeEdgeCost(PoseGraphMode mode, PoseGraphJacobians jacobians,
                                                  const geometry::Sim3& S_from_to,
                                                  const Matrix7d& information);

/// The vertex manifold matching makeEdgeCost(mode, jacobians, ...).
std::unique_ptr<ceres::Manifold> makeVertexManifold(PoseGraphMode mode,
                                                    PoseGraphJacobians jacobians);

/// The information matrix of the SE(3) residual: the 7x7 one without its sigma row and column.
Eigen::Matrix<double, 6, 6> se3Information(const Matrix7d& information);

}  // namespace scale_drift_slam::loop
