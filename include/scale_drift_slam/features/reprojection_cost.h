#pragma once
// The Ceres pieces shared by the window BA, the Ceres variant of motion-only BA and the two-view
// BA of map initialisation: the one reprojection residual of the package. Residuals are analytic
// (autodiff costs ~10x more per observation, and the window BA must stay under 30 ms for 10000
// observations, doc/benchmarks.md).

#include <ceres/ceres.h>

#include <Eigen/Core>

#include "scale_drift_slam/geometry/se3.h"

namespace scale_drift_slam::features {

/// The SE(3) pose stored as 7 numbers (qx qy qz qw tx ty tz, SE3::toData) with a 6-DoF left
/// update T <- exp(delta) T (doc/algorithm.md, "Lie groups").
/// Trick (as in VINS-Mono's pose parametrisation): PlusJacobian is [I_6; 0], and the cost
/// functions write d r / d delta into the first six columns of their 2x7 Jacobian and zero into
/// the last. Ceres only ever uses the product J * PlusJacobian, which is then exactly
/// d r / d delta, without a 7x6 chain rule per residual.
class SE3LeftManifold final : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 7; }
  int TangentSize() const override { return 6; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override {
    const geometry::SE3::Tangent xi = Eigen::Map<const geometry::SE3::Tangent>(delta);
    (geometry::SE3::exp(xi) * geometry::SE3::fromData(x)).toData(x_plus_delta);
    return true;
  }
  bool PlusJacobian(const double* x, double* jacobian) const override {
    Eigen::Map<Eigen::Matrix<double, 7, 6, Eigen::RowMajor>> J(jacobian);
    J.setZero();
    J.topRows<6>().setIdentity();
    return true;
  }
  /// y - x = log(y x^-1), the inverse of Plus.
  bool Minus(const double* y, const double* x, double* y_minus_x) const override {
    Eigen::Map<geometry::SE3::Tangent> difference(y_minus_x);
    difference = (geometry::SE3::fromData(y) * geometry::SE3::fromData(x).inverse()).log();
    return true;
  }
  bool MinusJacobian(const double* x, double* jacobian) const override {
    Eigen::Map<Eigen::Matrix<double, 6, 7, Eigen::RowMajor>> J(jacobian);
    J.setZero();
    J.leftCols<6>().setIdentity();
    return true;
  }
};

/// Points closer to the image plane than this (in the camera's z) are treated as unprojectable.
constexpr double kMinDepth = 1e-6;

/// The pixel residual r = f (z - proj(R x + t)) of one observation z (normalised coordinates) of
/// the world point x in the camera T_cam_world = (R, t), proj(y) = (y1/y3, y2/y3)
/// (doc/algorithm.md, "Notation"; scaled by the focal length f so that the robust kernel width
/// is in pixels). Jacobians with y = R x + t:
///   d r / d delta = -f dproj/dy [-[y]x, I]   (left update of the pose),
///   d r / d x     = -f dproj/dy R,
///   dproj/dy      = [1/y3, 0, -y1/y3^2; 0, 1/y3, -y2/y3^2].
/// Returns false when the point is not in front of the camera.
inline bool reprojectionResidual(const Eigen::Matrix3d& R_cam_world,
                                 const Eigen::Vector3d& t_cam_world, const Eigen::Vector3d& p_world,
                                 const Eigen::Vector2d& xy, double focal_length,
                                 Eigen::Vector2d* residual, Eigen::Matrix<double, 2, 6>* d_pose,
                                 Eigen::Matrix<double, 2, 3>* d_point) {
  const Eigen::Vector3d y = R_cam_world * p_world + t_cam_world;
  if (!(y.z() > kMinDepth)) return false;
  const double inv_z = 1.0 / y.z();
  const Eigen::Vector2d projected(y.x() * inv_z, y.y() * inv_z);
  *residual = focal_length * (xy - projected);
  if (d_pose == nullptr && d_point == nullptr) return true;
  // -f dproj/dy, written out.
  const double a = -focal_length * inv_z;
  Eigen::Matrix<double, 2, 3> d_proj;
  d_proj << a, 0.0, -a * projected.x(), 0.0, a, -a * projected.y();
  if (d_pose != nullptr) {
    // d_proj [-[y]x, I]; -[y]x = [0 y3 -y2; -y3 0 y1; y2 -y1 0].
    d_pose->col(0) = d_proj.col(1) * -y.z() + d_proj.col(2) * y.y();
    d_pose->col(1) = d_proj.col(0) * y.z() - d_proj.col(2) * y.x();
    d_pose->col(2) = -d_proj.col(0) * y.y() + d_proj.col(1) * y.x();
    d_pose->rightCols<3>() = d_proj;
  }
  if (d_point != nullptr) d_point->noalias() = d_proj * R_cam_world;
  return true;
}

inline bool reprojectionResidual(const geometry::SE3& T_cam_world, const Eigen::Vector3d& p_world,
                                 const Eigen::Vector2d& xy, double focal_length,
                                 Eigen::Vector2d* residual, Eigen::Matrix<double, 2, 6>* d_pose,
                                 Eigen::Matrix<double, 2, 3>* d_point) {
  return reprojectionResidual(T_cam_world.rotationMatrix(), T_cam_world.translation(), p_world, xy,
                              focal_length, residual, d_pose, d_point);
}

/// One observation as a Ceres cost: parameters are the pose (7 numbers, SE3LeftManifold) and the
/// world point (3 numbers).
class ReprojectionCost final : public ceres::SizedCostFunction<2, 7, 3> {
 public:
  ReprojectionCost(const Eigen::Vector2d& xy, double focal_length)
      : xy_(xy), focal_length_(focal_length) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    // The manifold keeps the quaternion at unit norm: no renormalisation per residual.
    const Eigen::Map<const Eigen::Quaterniond> q_cam_world(parameters[0]);
    const Eigen::Map<const Eigen::Vector3d> t_cam_world(parameters[0] + 4);
    const Eigen::Map<const Eigen::Vector3d> p_world(parameters[1]);
    Eigen::Vector2d r;
    Eigen::Matrix<double, 2, 6> d_pose;
    Eigen::Matrix<double, 2, 3> d_point;
    const bool want_pose = jacobians != nullptr && jacobians[0] != nullptr;
    const bool want_point = jacobians != nullptr && jacobians[1] != nullptr;
    if (!reprojectionResidual(q_cam_world.toRotationMatrix(), t_cam_world, p_world, xy_,
                              focal_length_, &r, want_pose ? &d_pose : nullptr,
                              want_point ? &d_point : nullptr)) {
      return false;
    }
    residuals[0] = r.x();
    residuals[1] = r.y();
    if (want_pose) {
      Eigen::Map<Eigen::Matrix<double, 2, 7, Eigen::RowMajor>> J(jacobians[0]);
      J.leftCols<6>() = d_pose;
      J.col(6).setZero();
    }
    if (want_point) {
      Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> J(jacobians[1]);
      J = d_point;
    }
    return true;
  }

 private:
  Eigen::Vector2d xy_;
  double focal_length_;
};

/// Pseudo-Huber rho(r) = 2 b^2 (sqrt(1 + (r/b)^2) - 1) (doc/algorithm.md, "Notation"). Ceres'
/// SoftLOneLoss(a) is rho(s) = 2 a^2 (sqrt(1 + s / a^2) - 1) of the squared norm s = |r|^2
/// (ceres/loss_function.h: "a^2 rho(s / a^2)" with rho(s) = 2 (sqrt(1 + s) - 1)), so with a = b
/// it is exactly the pseudo-Huber of |r|; Ceres minimises 1/2 sum rho, the same minimiser.
inline double pseudoHuber(double squared_norm, double width) {
  return 2.0 * width * width * (std::sqrt(1.0 + squared_norm / (width * width)) - 1.0);
}

}  // namespace scale_drift_slam::features
