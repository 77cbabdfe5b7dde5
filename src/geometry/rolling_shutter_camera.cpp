#include "scale_drift_slam/geometry/rolling_shutter_camera.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "scale_drift_slam/geometry/so3.h"

namespace scale_drift_slam::geometry {

RollingShutterCamera::RollingShutterCamera(std::shared_ptr<const CameraModel> base,
                                           const Eigen::Vector3d& rotation_rate,
                                           const Eigen::Vector3d& velocity, double scene_depth)
    : CameraModel(base ? base->calibration() : CameraCalibration()),
      base_(std::move(base)),
      rotation_rate_(rotation_rate),
      velocity_(velocity),
      scene_depth_(scene_depth) {
  if (!rotation_rate_.allFinite() || !velocity_.allFinite()) {
    throw std::invalid_argument("rolling-shutter camera: the motion is not finite");
  }
  if (!(scene_depth_ > 0.0 && std::isfinite(scene_depth_))) {
    throw std::invalid_argument("rolling-shutter camera: the scene depth must be > 0");
  }
}

double RollingShutterCamera::rowTime(double y) const {
  return calibration_.rolling_shutter_readout_s * ((y + 0.5) / calibration_.height - 0.5);
}

Eigen::Matrix3d RollingShutterCamera::rotationAt(double tau) const {
  return expSO3Matrix<double>(tau * rotation_rate_);
}

Eigen::Vector3d RollingShutterCamera::pointAt(double tau, const Eigen::Vector3d& p_cam) const {
  return rotationAt(tau) * p_cam + tau * velocity_;
}

double RollingShutterCamera::exposureTime(double y) const {
  return rowTime(std::clamp(y, -0.5, calibration_.height - 0.5));
}

std::optional<Eigen::Vector2d> RollingShutterCamera::project(const Eigen::Vector3d& p_cam) const {
  // The row the point lands in depends on the rotation at that row's time: a fixed point,
  // contracting by ~rate x readout x fy / height (0.08 for 150 deg/s, 30 ms and 500 px over 480
  // rows), so three steps from the global-shutter pixel reach a thousandth of a pixel. A pixel
  // beyond the frame's rows takes the nearest row's time (exposureTime): the "row time" of a
  // point 40 000 px off the image is over a second, and a turning camera would bring it in.
  std::optional<Eigen::Vector2d> pixel = base_->project(p_cam);
  for (int step = 0; step < 3 && pixel; ++step)
    pixel = base_->project(pointAt(exposureTime(pixel->y()), p_cam));
  return pixel;
}

Eigen::Matrix<double, 2, 3> RollingShutterCamera::projectionJacobian(
    const Eigen::Vector3d& p_cam) const {
  const std::optional<Eigen::Vector2d> pixel = project(p_cam);
  const double tau = pixel ? exposureTime(pixel->y()) : 0.0;
  return base_->projectionJacobian(pointAt(tau, p_cam)) * rotationAt(tau);
}

Eigen::Vector3d RollingShutterCamera::unproject(const Eigen::Vector2d& pixel) const {
  // The ray in the camera of the row's time, at the scene depth, moved back into the stamp's
  // camera frame.
  const double tau = exposureTime(pixel.y());
  const Eigen::Vector3d ray = base_->unproject(pixel);
  if (!(ray.z() > 1e-6)) return rotationAt(tau).transpose() * ray;  // no depth along it
  const Eigen::Vector3d p_tau = ray * (scene_depth_ / ray.z());
  return (rotationAt(tau).transpose() * (p_tau - tau * velocity_)).normalized();
}

std::shared_ptr<const CameraModel> frameCamera(const std::shared_ptr<const CameraModel>& base,
                                               const Eigen::Vector3d& rotation_rate,
                                               const Eigen::Vector3d& velocity,
                                               double scene_depth) {
  if (!base || !(base->calibration().rolling_shutter_readout_s > 0.0) ||
      !rotation_rate.allFinite() || !velocity.allFinite() ||
      !(scene_depth > 0.0 && std::isfinite(scene_depth))) {
    return base;
  }
  return std::make_shared<RollingShutterCamera>(base, rotation_rate, velocity, scene_depth);
}

std::shared_ptr<const CameraModel> turningFrameCamera(
    const std::shared_ptr<const CameraModel>& base, const Eigen::Vector3d& rotation_rate) {
  return frameCamera(base, rotation_rate, Eigen::Vector3d::Zero(), 1.0);
}

}  // namespace scale_drift_slam::geometry
