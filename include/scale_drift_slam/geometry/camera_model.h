#pragma once
// Camera models behind one interface: the SLAM asks for pixels of 3D points, the Jacobian of that
// projection, and the bearing of a pixel, and never looks at the lens model itself.

#include <memory>
#include <optional>

#include <Eigen/Core>

#include "scale_drift_slam/geometry/camera_calibration.h"

namespace scale_drift_slam::geometry {

/// A calibrated central camera. Immutable after construction; safe to share between threads.
class CameraModel {
 public:
  explicit CameraModel(const CameraCalibration& calibration);
  virtual ~CameraModel() = default;

  /// The pixel of a point given in the camera frame (z forward), or nothing when the point cannot
  /// be imaged (behind the camera, or outside the range where the lens model is one-to-one).
  virtual std::optional<Eigen::Vector2d> project(const Eigen::Vector3d& p_cam) const = 0;
  /// d pixel / d p_cam at a point that project() accepts.
  virtual Eigen::Matrix<double, 2, 3> projectionJacobian(const Eigen::Vector3d& p_cam) const = 0;
  /// The unit bearing (in the camera frame) of the ray through a pixel.
  virtual Eigen::Vector3d unproject(const Eigen::Vector2d& pixel) const = 0;

  /// The ray through a pixel on the plane z = 1 (undistorted normalised coordinates). Only for
  /// rays in front of the camera.
  Eigen::Vector2d undistortToNormalized(const Eigen::Vector2d& pixel) const;
  /// True when the pixel lies at least `border` pixels inside the image.
  bool isInImage(const Eigen::Vector2d& pixel, double border = 0.0) const;

  const CameraCalibration& calibration() const { return calibration_; }
  int width() const { return calibration_.width; }
  int height() const { return calibration_.height; }
  /// The linear part [fx 0 cx; 0 fy cy; 0 0 1].
  Eigen::Matrix3d K() const;

 protected:
  CameraCalibration calibration_;
};

/// Validates the calibration (throws std::invalid_argument with the reason) and builds its model.
std::unique_ptr<CameraModel> makeCameraModel(const CameraCalibration& calibration);

}  // namespace scale_drift_slam::geometry
