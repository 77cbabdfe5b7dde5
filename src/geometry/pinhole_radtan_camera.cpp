#include "scale_drift_slam/geometry/pinhole_radtan_camera.h"

#include <cmath>

#include <Eigen/Dense>

namespace scale_drift_slam::geometry {

PinholeRadTanCamera::PinholeRadTanCamera(const CameraCalibration& calibration)
    : CameraModel(calibration) {
  const auto& d = calibration_.distortion;
  if (d.size() >= 4) {
    k1_ = d[0];
    k2_ = d[1];
    p1_ = d[2];
    p2_ = d[3];
  }
  if (d.size() == 5) k3_ = d[4];
  // d(r d(r))/dr = 1 + 3 k1 r^2 + 5 k2 r^4 + 7 k3 r^6 must stay positive: find where it stops.
  max_radius_sq_ = 1e4;  // 89.4 degrees off-axis: nothing beyond is a pinhole image.
  for (double r_sq = 1e-3; r_sq < 1e4; r_sq *= 1.01) {
    if (1.0 + 3.0 * k1_ * r_sq + 5.0 * k2_ * r_sq * r_sq + 7.0 * k3_ * r_sq * r_sq * r_sq <= 0.0) {
      max_radius_sq_ = r_sq / 1.01;
      break;
    }
  }
}

Eigen::Vector2d PinholeRadTanCamera::distort(const Eigen::Vector2d& xy,
                                             Eigen::Matrix2d* jacobian) const {
  const double x = xy.x(), y = xy.y();
  const double r2 = x * x + y * y;
  const double radial = 1.0 + r2 * (k1_ + r2 * (k2_ + r2 * k3_));
  Eigen::Vector2d xy_d(x * radial + 2.0 * p1_ * x * y + p2_ * (r2 + 2.0 * x * x),
                       y * radial + p1_ * (r2 + 2.0 * y * y) + 2.0 * p2_ * x * y);
  if (jacobian) {
    // d radial / d x = 2 x (k1 + 2 k2 r^2 + 3 k3 r^4), likewise for y.
    const double dradial_dr2 = k1_ + r2 * (2.0 * k2_ + 3.0 * k3_ * r2);
    const double dradial_dx = 2.0 * x * dradial_dr2;
    const double dradial_dy = 2.0 * y * dradial_dr2;
    (*jacobian)(0, 0) = radial + x * dradial_dx + 2.0 * p1_ * y + 6.0 * p2_ * x;
    (*jacobian)(0, 1) = x * dradial_dy + 2.0 * p1_ * x + 2.0 * p2_ * y;
    (*jacobian)(1, 0) = y * dradial_dx + 2.0 * p1_ * x + 2.0 * p2_ * y;
    (*jacobian)(1, 1) = radial + y * dradial_dy + 6.0 * p1_ * y + 2.0 * p2_ * x;
  }
  return xy_d;
}

Eigen::Vector2d PinholeRadTanCamera::undistort(const Eigen::Vector2d& xy_distorted) const {
  Eigen::Vector2d xy = xy_distorted;
  for (int iteration = 0; iteration < 50; ++iteration) {
    Eigen::Matrix2d J;
    const Eigen::Vector2d residual = distort(xy, &J) - xy_distorted;
    const Eigen::Vector2d step = J.partialPivLu().solve(residual);
    xy -= step;
    if (step.squaredNorm() < 1e-28) break;
  }
  return xy;
}

std::optional<Eigen::Vector2d> PinholeRadTanCamera::project(const Eigen::Vector3d& p_cam) const {
  if (!(p_cam.z() > 0.0)) return std::nullopt;
  const Eigen::Vector2d xy = p_cam.head<2>() / p_cam.z();
  if (xy.squaredNorm() > max_radius_sq_) return std::nullopt;
  const Eigen::Vector2d xy_d = distort(xy);
  return Eigen::Vector2d(calibration_.fx * xy_d.x() + calibration_.cx,
                         calibration_.fy * xy_d.y() + calibration_.cy);
}

Eigen::Matrix<double, 2, 3> PinholeRadTanCamera::projectionJacobian(
    const Eigen::Vector3d& p_cam) const {
  const double inv_z = 1.0 / p_cam.z();
  const Eigen::Vector2d xy = p_cam.head<2>() * inv_z;
  Eigen::Matrix<double, 2, 3> dxy_dp;
  dxy_dp << inv_z, 0.0, -xy.x() * inv_z, 0.0, inv_z, -xy.y() * inv_z;
  Eigen::Matrix2d ddist_dxy;
  distort(xy, &ddist_dxy);
  const Eigen::Matrix2d F = Eigen::Vector2d(calibration_.fx, calibration_.fy).asDiagonal();
  return F * ddist_dxy * dxy_dp;
}

Eigen::Vector3d PinholeRadTanCamera::unproject(const Eigen::Vector2d& pixel) const {
  const Eigen::Vector2d xy_d((pixel.x() - calibration_.cx) / calibration_.fx,
                             (pixel.y() - calibration_.cy) / calibration_.fy);
  return undistort(xy_d).homogeneous().normalized();
}

}  // namespace scale_drift_slam::geometry
