#include "scale_drift_slam/geometry/camera_model.h"

#include "scale_drift_slam/geometry/equidistant_camera.h"
#include "scale_drift_slam/geometry/pinhole_radtan_camera.h"

namespace scale_drift_slam::geometry {

CameraModel::CameraModel(const CameraCalibration& calibration) : calibration_(calibration) {
  calibration_.validate();
}

Eigen::Vector2d CameraModel::undistortToNormalized(const Eigen::Vector2d& pixel) const {
  const Eigen::Vector3d bearing = unproject(pixel);
  return bearing.head<2>() / bearing.z();
}

bool CameraModel::isInImage(const Eigen::Vector2d& pixel, double border) const {
  return pixel.x() >= border && pixel.y() >= border && pixel.x() <= width() - 1 - border &&
         pixel.y() <= height() - 1 - border;
}

Eigen::Matrix3d CameraModel::K() const {
  Eigen::Matrix3d K;
  K << calibration_.fx, 0, calibration_.cx, 0, calibration_.fy, calibration_.cy, 0, 0, 1;
  return K;
}

std::unique_ptr<CameraModel> makeCameraModel(const CameraCalibration& calibration) {
  calibration.validate();
  if (calibration.model == DistortionModel::kEquidistant) {
    return std::make_unique<EquidistantCamera>(calibration);
  }
  return std::make_unique<PinholeRadTanCamera>(calibration);
}

}  // namespace scale_drift_slam::geometry
