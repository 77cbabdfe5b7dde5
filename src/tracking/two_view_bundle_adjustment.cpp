// Two-view bundle adjustment for map initialisation (declared in two_view_reconstruction.h).

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include "scale_drift_slam/tracking/two_view_reconstruction.h"

namespace scale_drift_slam::tracking {
namespace {

/// r = focal (proj(R p + t) - xy), proj(a) = (a1/a3, a2/a3) (doc/algorithm.md, "Notation");
/// R from the quaternion (x y z w, Eigen order), or the identity for the fixed first camera.
struct ReprojectionResidual {
  ReprojectionResidual(const Eigen::Vector2d& xy, double focal) : xy_(xy), focal_(focal) {}

  template <typename T>
  bool operator()(const T* q, const T* t, const T* p, T* residual) const {
    const Eigen::Quaternion<T> rotation(q[3], q[0], q[1], q[2]);
    const Eigen::Matrix<T, 3, 1> point(p[0], p[1], p[2]);
    const Eigen::Matrix<T, 3, 1> x = rotation * point + Eigen::Matrix<T, 3, 1>(t[0], t[1], t[2]);
    residual[0] = T(focal_) * (x[0] / x[2] - T(xy_.x()));
    residual[1] = T(focal_) * (x[1] / x[2] - T(xy_.y()));
    return true;
  }

  template <typename T>
  bool operator()(const T* p, T* residual) const {
    residual[0] = T(focal_) * (p[0] / p[2] - T(xy_.x()));
    residual[1] = T(focal_) * (p[1] / p[2] - T(xy_.y()));
    return true;
  }

  Eigen::Vector2d xy_;
  double focal_;
};

}  // namespace

void bundleAdjustTwoView(const std::vector<Eigen::Vector2d>& xy_first,
                         const std::vector<Eigen::Vector2d>& xy_second,
                         const std::vector<bool>& use, double focal_px, double huber_px,
                         int max_iterations, geometry::SE3* T_second_first,
                         std::vector<Eigen::Vector3d>* points_first) {
  if (max_iterations <= 0) return;
  double q[4] = {T_second_first->rotation().x(), T_second_first->rotation().y(),
                 T_second_first->rotation().z(), T_second_first->rotation().w()};
  const double baseline = T_second_first->translation().norm();
  if (!(baseline > 0.0)) return;
  double t[3] = {T_second_first->translation().x(), T_second_first->translation().y(),
                 T_second_first->translation().z()};
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::TAKE_OWNERSHIP;
  problem_options.loss_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  // Pseudo-Huber: Ceres' SoftLOneLoss(b) is rho(s) = 2 b^2 (sqrt(1 + s / b^2) - 1) of the squared
  // residual s = r^2 (ceres/loss_function.h), the paper's kernel; Ceres minimises 1/2 sum rho.
  ceres::LossFunction* loss = new ceres::SoftLOneLoss(huber_px);
  int used = 0;
  for (std::size_t i = 0; i < use.size(); ++i) {
    if (!use[i]) continue;
    double* p = (*points_first)[i].data();
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<ReprojectionResidual, 2, 3>(
                                 new ReprojectionResidual(xy_first[i], focal_px)),
                             loss, p);
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<ReprojectionResidual, 2, 4, 3, 3>(
                                 new ReprojectionResidual(xy_second[i], focal_px)),
                             loss, q, t, p);
    ++used;
  }
  if (used < 5) return;
  problem.SetManifold(q, new ceres::EigenQuaternionManifold);
  // The baseline length is the scale gauge of two views: keep |t| fixed on its sphere.
  problem.SetManifold(t, new ceres::SphereManifold<3>);
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::SPARSE_SCHUR;
  options.max_num_iterations = max_iterations;
  options.num_threads = 1;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  *T_second_first =
      geometry::SE3(Eigen::Quaterniond(q[3], q[0], q[1], q[2]), Eigen::Vector3d(t[0], t[1], t[2]));
}

}  // namespace scale_drift_slam::tracking
