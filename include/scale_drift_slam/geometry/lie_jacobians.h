#pragma once
// Derivatives of the Lie-group maps used by relative-pose residuals (doc/algorithm.md, "Lie
// groups" and "Loop closure correction"): the algebra adjoint ad(xi) and the left Jacobian of
// exp, for SE(3) (tangent (omega, upsilon)) and Sim(3) (tangent (omega, sigma, upsilon)).
//   exp(xi + d) = exp(Jl(xi) d) exp(xi) + O(d^2),   log(exp(e) exp(xi)) = xi + Jl(xi)^-1 e +
//   O(e^2), Jl(xi) = sum_n ad(xi)^n / (n+1)! = integral_0^1 Adj(exp(t xi)) dt, Jl(xi)^-1 = sum_n
//   B_n ad(xi)^n / n! = I - ad/2 + ad^2/12 - ad^4/720 + ...  (Bernoulli B_n).
// Double precision only (the residuals that use them supply analytic Jacobians to Ceres).

#include <Eigen/Core>

#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/geometry/sim3.h"

namespace scale_drift_slam::geometry {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Matrix7d = Eigen::Matrix<double, 7, 7>;

/// ad(xi) xi2 = [xi, xi2] (the Lie bracket of se(3)): [[W, 0], [U, W]], W = [omega]x,
/// U = [upsilon]x.
Matrix6d adSE3(const SE3::Tangent& xi);
/// ad of sim(3): [[W, 0, 0], [0, 0, 0], [U, -upsilon, W + sigma I]].
Matrix7d adSim3(const Sim3::Tangent& xi);

/// X Y for tangent-space maps with the block structure that ad(xi), Adj(S) and Jl(xi)^(+-1) share
/// (the rotation rows depend on the rotation only, the scale row on the scale only):
///   Sim(3): [[A, 0, 0], [0, s, 0], [C, b, D]],   SE(3): [[A, 0], [C, D]]   (3x3 blocks).
/// Only the structurally non-zero blocks are formed: four 3x3 products instead of a full one.
/// Entries outside the structure are taken as zero.
Matrix7d multiplyTangentMaps(const Matrix7d& X, const Matrix7d& Y);
Matrix6d multiplyTangentMaps(const Matrix6d& X, const Matrix6d& Y);

/// Jl(xi). A power series in ad(xi) while theta^2 + sigma^2 is small, otherwise 16-point
/// Gauss-Legendre quadrature of integral_0^1 Adj(exp(t xi)) dt (exact to ~1e-14 relative for
/// |sigma| + theta up to ~20).
Matrix6d leftJacobianSE3(const SE3::Tangent& xi);
Matrix7d leftJacobianSim3(const Sim3::Tangent& xi);

/// Jl(xi)^-1. The Bernoulli series for theta^2 + sigma^2 < 0.25 (truncation below 1e-12 relative,
/// the common case of a nearly satisfied residual), otherwise the inverse of Jl above.
Matrix6d inverseLeftJacobianSE3(const SE3::Tangent& xi);
Matrix7d inverseLeftJacobianSim3(const Sim3::Tangent& xi);

}  // namespace scale_drift_slam::geometry
