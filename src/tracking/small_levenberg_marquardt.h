#pragma once
// Internal to the tracking module: Levenberg-Marquardt on a 3-vector (a feature's inverse-depth
// state or a point), for the cost functions of the depth filter and of feature promotion. Eigen's
// 3x3 LDLT per step; no allocation.

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/Core>

namespace scale_drift_slam::tracking::internal {

struct SmallLmOptions {
  int max_iterations = 10;        ///< Accepted steps at most.
  double initial_damping = 1e-3;  ///< mu of the first step.
  double min_diagonal = 0.0;      ///< Floor of diag(H) in the damping (for flat directions).
};

/// Minimises cost(x) from x: `evaluate(x, H, g)` returns the cost at x (infinity where x is
/// infeasible) and, when H is not null, the Gauss-Newton system H dx = -g there. Each step solves
/// (H + mu diag(max(H_ii, min_diagonal))) dx = -g, takes it if the cost falls (mu / 10, at least
/// 1e-10) and retries with mu x 10 otherwise (8 tries); stops when the relative fall is below
/// 1e-10 or no step lowers the cost. Returns the final cost; x holds the minimiser.
template <typename Evaluate>
double minimiseSmallLm(Eigen::Vector3d* x, const SmallLmOptions& options, Evaluate evaluate) {
  Eigen::Matrix3d H;
  Eigen::Vector3d g;
  double cost = evaluate(*x, &H, &g);
  if (!std::isfinite(cost)) return cost;
  double mu = options.initial_damping;
  for (int iteration = 0; iteration < options.max_iterations; ++iteration) {
    bool accepted = false, converged = false;
    for (int attempt = 0; attempt < 8 && !accepted; ++attempt) {
      Eigen::Matrix3d A = H;
      A.diagonal() += mu * H.diagonal().cwiseMax(options.min_diagonal);
      const Eigen::Vector3d x_new = *x - A.ldlt().solve(g);
      const double cost_new = evaluate(x_new, nullptr, nullptr);
      if (cost_new < cost) {
        converged = cost - cost_new < 1e-10 * cost + 1e-14;
        *x = x_new;
        cost = evaluate(*x, &H, &g);
        mu = std::max(mu * 0.1, 1e-10);
        accepted = true;
      } else {
        mu *= 10.0;
      }
    }
    if (!accepted || converged) break;  // no step lowers the cost: at its minimum up to numerics
  }
  return cost;
}

}  // namespace scale_drift_slam::tracking::internal
