// Every calibration shipped in config/ loads, validates and gives a usable camera model.

#include <gtest/gtest.h>

#include "scale_drift_slam/geometry/camera_model.h"
#include "scale_drift_slam/io/calibration_io.h"

namespace scale_drift_slam::io {
namespace {

class ShippedCalibration : public ::testing::TestWithParam<std::string> {};

TEST_P(ShippedCalibration, LoadsAndRoundTripsThePrincipalPoint) {
  const std::string path = std::string(SDS_TEST_DATA_DIR) + "/../../config/" + GetParam();
  const geometry::CameraCalibration calibration = loadCalibrationYaml(path);
  const auto camera = geometry::makeCameraModel(calibration);
  const Eigen::Vector2d centre(calibration.cx, calibration.cy);
  const auto pixel = camera->project(camera->unproject(centre));
  ASSERT_TRUE(pixel.has_value());
  EXPECT_LT((*pixel - centre).norm(), 1e-9);
}

INSTANTIATE_TEST_SUITE_P(Config, ShippedCalibration,
                         ::testing::Values("euroc_cam0.yaml", "tum_fr1.yaml", "tum_fr2.yaml",
                                           "tum_fr3.yaml"));

}  // namespace
}  // namespace scale_drift_slam::io
