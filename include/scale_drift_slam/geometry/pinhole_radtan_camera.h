#pragma once
// Pinhole with radial-tangential distortion (OpenCV, ROS plumb_bob): for x = X/Z, y = Y/Z,
// r^2 = x^2 + y^2, d = 1 + k1 r^2 + k2 r^4 + k3 r^6,
//   x_d = x d + 2 p1 x y + p2 (r^2 + 2 x^2),   y_d = y d + p1 (r^2 + 2 y^2) + 2 p2 x y,
//   u = fx x_d + cx,                            v = fy y_d + cy.

#include "scale_drift_slam/geometry/camera_model.h"

namespace scale_drift_slam::geometry {

class PinholeRadTanCamera final : public CameraModel {
 public:
  explicit PinholeRadTanCamera(const CameraCalibration& calibration);

  std::optional<Eigen::Vector2d> project(const Eigen::Vector3d& p_cam) const override;
  Eigen::Matrix<double, 2, 3> projectionJacobian(const Eigen::Vector3d& p_cam) const override;
  Eigen::Vector3d unproject(const Eigen::Vector2d& pixel) const override;

  /// Normalised undistorted -> normalised distorted coordinates, with d(distorted)/d(undistorted).
  Eigen::Vector2d distort(const Eigen::Vector2d& xy, Eigen::Matrix2d* jacobian = nullptr) const;
  /// The inverse of distort(), by Gauss-Newton (converges to 1e-14 inside the valid radius).
  Eigen::Vector2d undistort(const Eigen::Vector2d& xy_distorted) const;

 private:
  double k1_ = 0, k2_ = 0, p1_ = 0, p2_ = 0, k3_ = 0;
  /// Squared radius beyond which the radial map r -> r d(r) stops increasing (the lens model
  /// folds back there, so points beyond it are not imaged).
  double max_radius_sq_ = 0;
};

}  // namespace scale_drift_slam::geometry
