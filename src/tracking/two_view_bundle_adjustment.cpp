// Two-view bundle adjustment for map initialisation (declared in two_view_reconstruction.h), with
// the shared reprojection cost of the window BA (features/reprojection_cost.h).

#include <array>
#include <deque>

#include <ceres/ceres.h>

#include "scale_drift_slam/features/reprojection_cost.h"
#include "scale_drift_slam/tracking/two_view_reconstruction.h"

namespace scale_drift_slam::tracking {

void bundleAdjustTwoView(const std::vector<Eigen::Vector2d>& xy_first,
                         const std::vector<Eigen::Vector2d>& xy_second,
                         const std::vector<bool>& use, double focal_px, double huber_px,
                         int max_iterations, geometry::SE3* T_second_first,
                         std::vector<Eigen::Vector3d>* points_first) {
  if (max_iterations <= 0) return;
  const double baseline = T_second_first->translation().norm();
  if (!(baseline > 0.0)) return;
  // Poses as features::ReprojectionCost takes them (7 numbers, SE3::toData): the first camera is
  // the world origin, held constant; the second moves on the SE(3) manifold.
  std::array<double, 7> T_first_first{}, T_second_first_data{};
  geometry::SE3().toData(T_first_first.data());
  T_second_first->toData(T_second_first_data.data());

  // The problem borrows costs, kernel and manifold: they live on this stack frame.
  ceres::Problem::Options problem_options;
  problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  ceres::SoftLOneLoss pseudo_huber(huber_px);  // see features::pseudoHuber
  features::SE3LeftManifold se3_manifold;
  std::deque<features::ReprojectionCost> costs;  // stable addresses, no copies
  int used = 0;
  for (std::size_t i = 0; i < use.size(); ++i) {
    if (!use[i]) continue;
    double* p = (*points_first)[i].data();
    costs.emplace_back(xy_first[i], focal_px);
    problem.AddResidualBlock(&costs.back(), &pseudo_huber, T_first_first.data(), p);
    costs.emplace_back(xy_second[i], focal_px);
    problem.AddResidualBlock(&costs.back(), &pseudo_huber, T_second_first_data.data(), p);
    ++used;
  }
  if (used < 5) return;
  problem.SetParameterBlockConstant(T_first_first.data());
  problem.SetManifold(T_second_first_data.data(), &se3_manifold);
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::SPARSE_SCHUR;
  options.max_num_iterations = max_iterations;
  options.num_threads = 1;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);

  // The scale of two views is a gauge the cost does not see (scaling the baseline and all points
  // together changes no residual), and the SE(3) manifold leaves it free: the solution is scaled
  // back to the baseline it started with, as the fixed-length baseline of a sphere would keep it.
  const geometry::SE3 T = geometry::SE3::fromData(T_second_first_data.data());
  const double length = T.translation().norm();
  if (!(length > 0.0) || !std::isfinite(length)) return;
  const double scale = baseline / length;
  *T_second_first = geometry::SE3(T.rotation(), T.translation() * scale);
  for (std::size_t i = 0; i < use.size(); ++i) {
    if (use[i]) (*points_first)[i] *= scale;
  }
}

}  // namespace scale_drift_slam::tracking
