// Camera models: project after unproject returns the pixel over the whole image (sub-millipixel,
// including strong EuRoC distortion and a fisheye lens), analytic Jacobians equal numeric ones,
// and invalid calibrations are refused with a reason.

#include <cmath>
#include <limits>
#include <random>

#include <gtest/gtest.h>

#include "scale_drift_slam/geometry/camera_model.h"
#include "scale_drift_slam/geometry/pinhole_radtan_camera.h"

namespace scale_drift_slam::geometry {
namespace {

CameraCalibration linearPinhole() {
  CameraCalibration c;
  c.fx = 195;
  c.fy = 195;
  c.cx = 162;
  c.cy = 125;
  c.width = 320;
  c.height = 240;
  return c;
}

/// EuRoC MAV cam0 (Kalibr calibration shipped with the dataset).
CameraCalibration eurocCam0() {
  CameraCalibration c;
  c.fx = 458.654;
  c.fy = 457.296;
  c.cx = 367.215;
  c.cy = 248.375;
  c.width = 752;
  c.height = 480;
  c.distortion = {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05};
  return c;
}

/// TUM-VI cam0, a 195-degree equidistant fisheye.
CameraCalibration tumViFisheye() {
  CameraCalibration c;
  c.model = DistortionModel::kEquidistant;
  c.fx = 190.97847715128717;
  c.fy = 190.9733070521226;
  c.cx = 254.93170605935475;
  c.cy = 256.8974428996504;
  c.width = 512;
  c.height = 512;
  c.distortion = {0.0034823894022493434, 0.0007150348452162257, -0.0020532361418706202,
                  0.00020293673591811182};
  return c;
}

/// A wide plumb_bob lens with k3, as ROS users get from camera_calibration.
CameraCalibration strongRadTanWithK3() {
  CameraCalibration c = eurocCam0();
  c.distortion = {-0.35, 0.12, 0.001, -0.0005, -0.015};
  return c;
}

class CameraModelTest : public ::testing::TestWithParam<CameraCalibration> {};

TEST_P(CameraModelTest, ProjectAfterUnprojectReturnsThePixelEverywhere) {
  const auto camera = makeCameraModel(GetParam());
  double worst = 0.0;
  for (double v = 0.0; v <= camera->height() - 1; v += 0.5 * (camera->height() - 1) / 40) {
    for (double u = 0.0; u <= camera->width() - 1; u += 0.5 * (camera->width() - 1) / 40) {
      const Eigen::Vector2d pixel(u, v);
      const Eigen::Vector3d bearing = camera->unproject(pixel);
      ASSERT_NEAR(bearing.norm(), 1.0, 1e-12);
      const auto reprojected = camera->project(bearing * 3.7);
      ASSERT_TRUE(reprojected.has_value()) << pixel.transpose();
      worst = std::max(worst, (*reprojected - pixel).norm());
    }
  }
  EXPECT_LT(worst, 1e-3) << "worst round trip error in pixels";
  EXPECT_LT(worst, 1e-6) << "(the solvers converge far below the required millipixel)";
}

TEST_P(CameraModelTest, UnprojectAfterProjectReturnsTheBearing) {
  const auto camera = makeCameraModel(GetParam());
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0, camera->width() - 1), v(0, camera->height() - 1);
  std::uniform_real_distribution<double> depth(0.2, 50.0);
  for (int i = 0; i < 500; ++i) {
    const Eigen::Vector3d p = camera->unproject({u(rng), v(rng)}) * depth(rng);
    const auto pixel = camera->project(p);
    ASSERT_TRUE(pixel.has_value());
    EXPECT_LT((camera->unproject(*pixel) - p.normalized()).norm(), 1e-9);
  }
}

TEST_P(CameraModelTest, ProjectionJacobianMatchesNumericDerivative) {
  const auto camera = makeCameraModel(GetParam());
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(0, camera->width() - 1), v(0, camera->height() - 1);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d p = camera->unproject({u(rng), v(rng)}) * 2.5;
    const Eigen::Matrix<double, 2, 3> J = camera->projectionJacobian(p);
    Eigen::Matrix<double, 2, 3> numeric;
    const double h = 1e-6;
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector3d d = Eigen::Vector3d::Zero();
      d[k] = h;
      numeric.col(k) = (*camera->project(p + d) - *camera->project(p - d)) / (2 * h);
    }
    EXPECT_LT((J - numeric).norm(), 1e-5 * std::max(1.0, numeric.norm())) << p.transpose();
  }
}

TEST_P(CameraModelTest, PointsBehindTheCameraAreNotImaged) {
  const auto camera = makeCameraModel(GetParam());
  EXPECT_FALSE(camera->project(Eigen::Vector3d(0.0, 0.0, -1.0)).has_value());
  EXPECT_FALSE(camera->project(Eigen::Vector3d(0.1, -0.2, -5.0)).has_value());
}

INSTANTIATE_TEST_SUITE_P(Models, CameraModelTest,
                         ::testing::Values(linearPinhole(), eurocCam0(), strongRadTanWithK3(),
                                           tumViFisheye()));

TEST(PinholeRadTanCamera, DoesNotImagePointsWhereTheLensModelFolds) {
  // With k1 = -0.35, k2 = 0.12, k3 = -0.015 the radial map r d(r) stops increasing near
  // r = 1.9: a point far off-axis must not wrap back into the image.
  const auto camera = makeCameraModel(strongRadTanWithK3());
  EXPECT_FALSE(camera->project(Eigen::Vector3d(4.0, 0.0, 1.0)).has_value());
  EXPECT_TRUE(camera->project(Eigen::Vector3d(1.5, 0.0, 1.0)).has_value());
  // EuRoC's lens never folds: the off-axis point lands far outside the image instead.
  const auto euroc = makeCameraModel(eurocCam0());
  const auto far = euroc->project(Eigen::Vector3d(4.0, 0.0, 1.0));
  ASSERT_TRUE(far.has_value());
  EXPECT_FALSE(euroc->isInImage(*far));
}

TEST(EquidistantCamera, ImagesBeyondNinetyDegreesButNotBehind) {
  const auto camera = makeCameraModel(tumViFisheye());
  // TUM-VI's lens sees 97 degrees off-axis at the image corners.
  const double angle = 95.0 * M_PI / 180.0;
  const auto pixel = camera->project(Eigen::Vector3d(std::sin(angle), 0.0, std::cos(angle)));
  ASSERT_TRUE(pixel.has_value());
  EXPECT_GT(pixel->x(), camera->width() - 1 - 20.0);
  EXPECT_NEAR(camera->unproject(*pixel).z(), std::cos(angle), 1e-9);
}

TEST(PinholeRadTanCamera, LinearModelIsTheTextbookPinhole) {
  const auto camera = makeCameraModel(linearPinhole());
  const auto pixel = camera->project(Eigen::Vector3d(1.0, -0.5, 2.0));
  ASSERT_TRUE(pixel.has_value());
  EXPECT_NEAR(pixel->x(), 195 * 0.5 + 162, 1e-12);
  EXPECT_NEAR(pixel->y(), 195 * -0.25 + 125, 1e-12);
}

TEST(CameraCalibration, InvalidCalibrationsAreRefusedWithAReason) {
  auto expect_refused = [](CameraCalibration c, const std::string& reason) {
    try {
      makeCameraModel(c);
      ADD_FAILURE() << "accepted a calibration with " << reason;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(reason), std::string::npos) << e.what();
    }
  };
  CameraCalibration c = eurocCam0();
  c.fx = 0.0;
  expect_refused(c, "focal lengths must be positive");
  c = eurocCam0();
  c.fy = -195.0;
  expect_refused(c, "focal lengths must be positive");
  c = eurocCam0();
  c.cx = std::numeric_limits<double>::quiet_NaN();
  expect_refused(c, "cx is not a finite number");
  c = eurocCam0();
  c.distortion = {0.1, 0.2, 0.3};
  expect_refused(c, "plumb_bob takes 0, 4 or 5 coefficients");
  c = tumViFisheye();
  c.distortion.push_back(0.0);
  expect_refused(c, "equidistant takes 4 coefficients");
  c = eurocCam0();
  c.distortion[1] = std::numeric_limits<double>::infinity();
  expect_refused(c, "distortion coefficient 1 is not a finite number");
  c = eurocCam0();
  c.width = 0;
  expect_refused(c, "image size must be positive");
  EXPECT_THROW(parseDistortionModel("rational_polynomial"), std::invalid_argument);
}

TEST(CameraCalibration, JitterIsTheSameCameraARealChangeIsNot) {
  CameraCalibration a;
  a.fx = 525.0;
  a.fy = 525.0;
  a.cx = 319.5;
  a.cy = 239.5;
  a.width = 640;
  a.height = 480;
  a.distortion = {0.26, -0.95, -0.005, 0.003, 1.16};
  CameraCalibration jitter = a;  // a CameraInfo republished with 0.01 px of noise
  jitter.fx += 0.01;
  jitter.cy -= 0.01;
  jitter.distortion[0] += 1e-6;
  EXPECT_TRUE(a.sameCameraAs(jitter));
  // Another calibration: each of these moves the image by more than half a pixel.
  for (int change = 0; change < 5; ++change) {
    CameraCalibration other = a;
    if (change == 0) other.fx += 2.0;  // 2 px of focal length: 1.2 px at the image's edge
    if (change == 1) other.cx += 1.0;
    if (change == 2) other.distortion[0] += 0.01;
    if (change == 3) other.width = 752;
    if (change == 4) other.model = DistortionModel::kEquidistant;
    if (change == 4) other.distortion = {0.0, 0.0, 0.0, 0.0};
    EXPECT_FALSE(a.sameCameraAs(other)) << "change " << change;
  }
}

}  // namespace
}  // namespace scale_drift_slam::geometry
