#pragma once
// A rolling-shutter camera during one frame: the rows are exposed one after the other while the
// camera moves, so a point's pixel depends on the row it lands in. Measured from the pose at the
// middle row's time (the frame's stamp), row y is seen from the camera of time
// tau(y) = readout x ((y + 0.5) / height - 0.5), which maps a point p of the stamp's camera frame
// to exp(tau [w]x) p + tau v (first order: a constant rotation rate w and velocity v over the
// frame). Projecting a point is exact in this model; a pixel's ray needs the point's depth for
// the translation, and takes the scene depth (a hand-held camera at 1 m/s, a 30 ms readout and
// points at 1-4 m around a 2 m scene depth: the ray off by ~2 px at the top and bottom rows, where
// leaving the translation out is off by ~4).
// Everything the tracker does with one frame's pixels goes through this model, so the poses,
// observations and depths it produces are those of a global-shutter camera at the frame's stamp.
#include <memory>

#include <Eigen/Core>

#include "scale_drift_slam/geometry/camera_model.h"

namespace scale_drift_slam::geometry {

class RollingShutterCamera : public CameraModel {
 public:
  /// `rotation_rate` w (rad/s) and `velocity` v (m/s, in the camera frame): a point p of the
  /// camera frame at the frame's stamp is at exp(tau [w]x) p + tau v in the camera frame of time
  /// tau after it (for a constant frame-to-frame motion T_cur_prev = (R, t) over dt:
  /// w = log(R) / dt, v = t / dt). `scene_depth` (> 0) is the depth unproject() assumes. The
  /// readout time is the base calibration's rolling_shutter_readout_s.
  RollingShutterCamera(std::shared_ptr<const CameraModel> base,
                       const Eigen::Vector3d& rotation_rate,
                       const Eigen::Vector3d& velocity = Eigen::Vector3d::Zero(),
                       double scene_depth = 1.0);

  std::optional<Eigen::Vector2d> project(const Eigen::Vector3d& p_cam) const override;
  /// The Jacobian of the row's projection at the point's row (the row's own change with the
  /// point, ~rate x readout x f / height of a pixel per pixel, is left out).
  Eigen::Matrix<double, 2, 3> projectionJacobian(const Eigen::Vector3d& p_cam) const override;
  Eigen::Vector3d unproject(const Eigen::Vector2d& pixel) const override;

  /// The time of a row relative to the frame's stamp (s).
  double rowTime(double y) const;
  /// The time a pixel of row y is exposed at: rowTime of y clamped to the frame's rows (a point
  /// projected above or below the image is seen from the camera of the first or last row).
  double exposureTime(double y) const;
  /// The rotation from the stamp's camera frame to the camera frame of time `tau`.
  Eigen::Matrix3d rotationAt(double tau) const;
  /// A point of the stamp's camera frame in the camera frame of time `tau`.
  Eigen::Vector3d pointAt(double tau, const Eigen::Vector3d& p_cam) const;

 private:
  std::shared_ptr<const CameraModel> base_;
  Eigen::Vector3d rotation_rate_;
  Eigen::Vector3d velocity_;
  double scene_depth_;
};

/// The camera to measure one frame with: `base` itself for a global shutter (readout 0), else a
/// RollingShutterCamera moving at `rotation_rate` and `velocity`.
std::shared_ptr<const CameraModel> frameCamera(const std::shared_ptr<const CameraModel>& base,
                                               const Eigen::Vector3d& rotation_rate,
                                               const Eigen::Vector3d& velocity, double scene_depth);
/// The same for a camera that only turns (no translation during the readout, so no scene depth).
std::shared_ptr<const CameraModel> turningFrameCamera(
    const std::shared_ptr<const CameraModel>& base, const Eigen::Vector3d& rotation_rate);

}  // namespace scale_drift_slam::geometry
