#pragma once
// Equidistant fisheye (Kannala-Brandt; OpenCV fisheye, ROS equidistant): for the angle theta
// between the ray and the optical axis, theta_d = theta (1 + k1 theta^2 + k2 theta^4 +
// k3 theta^6 + k4 theta^8), and the pixel is (fx theta_d X / rho + cx, fy theta_d Y / rho + cy)
// with rho = sqrt(X^2 + Y^2). Rays beyond 90 degrees are imaged while theta_d still grows.

#include "scale_drift_slam/geometry/camera_model.h"

namespace scale_drift_slam::geometry {

class EquidistantCamera final : public CameraModel {
 public:
  explicit EquidistantCamera(const CameraCalibration& calibration);

  std::optional<Eigen::Vector2d> project(const Eigen::Vector3d& p_cam) const override;
  Eigen::Matrix<double, 2, 3> projectionJacobian(const Eigen::Vector3d& p_cam) const override;
  Eigen::Vector3d unproject(const Eigen::Vector2d& pixel) const override;

 private:
  /// theta_d(theta) and its derivative.
  double distortAngle(double theta, double* derivative = nullptr) const;

  double k_[4] = {0, 0, 0, 0};
  double max_theta_ = 0;  ///< Largest angle where theta_d is still increasing (<= pi).
};

}  // namespace scale_drift_slam::geometry
