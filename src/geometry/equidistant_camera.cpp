#include "scale_drift_slam/geometry/equidistant_camera.h"

#include <algorithm>
#include <cmath>

namespace scale_drift_slam::geometry {

EquidistantCamera::EquidistantCamera(const CameraCalibration& calibration)
    : CameraModel(calibration) {
  for (int i = 0; i < 4; ++i)
    k_[i] = calibration_.distortion[i];
  // theta_d must keep increasing (else the model folds back) ...
  double fold_theta = M_PI;
  for (double theta = 1e-3; theta < M_PI; theta += 1e-3) {
    double derivative = 0.0;
    distortAngle(theta, &derivative);
    if (derivative <= 0.0) {
      fold_theta = theta - 1e-3;
      break;
    }
  }
  // ... and rays far beyond the image corners are not imaged (a 10 degree margin).
  double corner_theta_d = 0.0;
  for (double u : {0.0, calibration_.width - 1.0}) {
    for (double v : {0.0, calibration_.height - 1.0}) {
      corner_theta_d =
          std::max(corner_theta_d, std::hypot((u - calibration_.cx) / calibration_.fx,
                                              (v - calibration_.cy) / calibration_.fy));
    }
  }
  max_theta_ = fold_theta;
  const double corner_theta = std::acos(
      unproject({calibration_.cx + corner_theta_d * calibration_.fx, calibration_.cy}).z());
  max_theta_ = std::min(fold_theta, corner_theta + 10.0 * M_PI / 180.0);
}

double EquidistantCamera::distortAngle(double theta, double* derivative) const {
  const double t2 = theta * theta;
  const double poly = 1.0 + t2 * (k_[0] + t2 * (k_[1] + t2 * (k_[2] + t2 * k_[3])));
  if (derivative) {
    // d/dtheta [theta poly] = 1 + 3 k1 t^2 + 5 k2 t^4 + 7 k3 t^6 + 9 k4 t^8.
    *derivative =
        1.0 + t2 * (3.0 * k_[0] + t2 * (5.0 * k_[1] + t2 * (7.0 * k_[2] + t2 * 9.0 * k_[3])));
  }
  return theta * poly;
}

std::optional<Eigen::Vector2d> EquidistantCamera::project(const Eigen::Vector3d& p_cam) const {
  const double rho = p_cam.head<2>().norm();
  const double theta = std::atan2(rho, p_cam.z());
  if (!(theta < max_theta_) || (rho == 0.0 && p_cam.z() <= 0.0)) return std::nullopt;
  // theta_d / rho; near the axis theta ~ rho / z, so the ratio tends to 1/z.
  const double scale =
      rho > 1e-12 * std::abs(p_cam.z()) ? distortAngle(theta) / rho : 1.0 / p_cam.z();
  return Eigen::Vector2d(calibration_.fx * scale * p_cam.x() + calibration_.cx,
                         calibration_.fy * scale * p_cam.y() + calibration_.cy);
}

Eigen::Matrix<double, 2, 3> EquidistantCamera::projectionJacobian(
    const Eigen::Vector3d& p_cam) const {
  const double X = p_cam.x(), Y = p_cam.y(), Z = p_cam.z();
  const double rho_sq = X * X + Y * Y;
  const double rho = std::sqrt(rho_sq);
  Eigen::Matrix<double, 2, 3> J;
  if (rho < 1e-9 * std::abs(Z)) {
    // On the axis the model is a pinhole to first order.
    J << 1.0 / Z, 0.0, -X / (Z * Z), 0.0, 1.0 / Z, -Y / (Z * Z);
  } else {
    const double theta = std::atan2(rho, Z);
    double g_prime = 0.0;
    const double g = distortAngle(theta, &g_prime);
    const double f = g / rho;  // x' = f X, y' = f Y
    const double r_sq = rho_sq + Z * Z;
    // dtheta/dX = Z X / (rho r^2), dtheta/dZ = -rho / r^2.
    const Eigen::Vector3d dtheta(Z * X / (rho * r_sq), Z * Y / (rho * r_sq), -rho / r_sq);
    const Eigen::Vector3d drho(X / rho, Y / rho, 0.0);
    const Eigen::Vector3d df = (g_prime * dtheta - f * drho) / rho;
    J.row(0) = X * df.transpose();
    J.row(1) = Y * df.transpose();
    J(0, 0) += f;
    J(1, 1) += f;
  }
  J.row(0) *= calibration_.fx;
  J.row(1) *= calibration_.fy;
  return J;
}

Eigen::Vector3d EquidistantCamera::unproject(const Eigen::Vector2d& pixel) const {
  const Eigen::Vector2d xy_d((pixel.x() - calibration_.cx) / calibration_.fx,
                             (pixel.y() - calibration_.cy) / calibration_.fy);
  const double theta_d = xy_d.norm();
  if (theta_d < 1e-12) return Eigen::Vector3d(xy_d.x(), xy_d.y(), 1.0).normalized();
  // Newton on theta_d(theta) = theta_d, started at theta = theta_d.
  double theta = std::min(theta_d, max_theta_);
  for (int iteration = 0; iteration < 50; ++iteration) {
    double derivative = 0.0;
    const double step = (distortAngle(theta, &derivative) - theta_d) / derivative;
    theta = std::clamp(theta - step, 0.0, max_theta_);
    if (std::abs(step) < 1e-15) break;
  }
  const double s = std::sin(theta) / theta_d;
  return Eigen::Vector3d(s * xy_d.x(), s * xy_d.y(), std::cos(theta));
}

}  // namespace scale_drift_slam::geometry
