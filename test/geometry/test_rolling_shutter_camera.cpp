// The rolling-shutter camera of one frame against a brute-force simulation of the shutter: each
// row exposed at its own time from a camera turning and moving at a constant rate. A point's
// pixel is found by searching the row whose camera images the point in that very row; the model
// must agree to a thousandth of a pixel, and the ray it gives a pixel must be the point's
// direction in the camera of the frame's stamp (exactly at the scene depth it assumes).

#include <cmath>
#include <memory>
#include <random>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "scale_drift_slam/geometry/rolling_shutter_camera.h"

namespace scale_drift_slam::geometry {
namespace {

CameraCalibration rollingShutterVga(double readout_s) {
  CameraCalibration c;
  c.fx = c.fy = 502.3;
  c.cx = 319.5;
  c.cy = 239.5;
  c.width = 640;
  c.height = 480;
  c.distortion = {-0.28, 0.07, 0.0002, 0.00002};  // a strong lens, as EuRoC's
  c.rolling_shutter_readout_s = readout_s;
  return c;
}

/// A point p of the stamp's camera in the camera of time tau after it: R(tau) p + tau v.
Eigen::Vector3d moved(const Eigen::Vector3d& rate, const Eigen::Vector3d& velocity, double tau,
                      const Eigen::Vector3d& p) {
  const Eigen::Vector3d angle_axis = tau * rate;
  const Eigen::Matrix3d R =
      angle_axis.norm() == 0.0
          ? Eigen::Matrix3d::Identity()
          : Eigen::AngleAxisd(angle_axis.norm(), angle_axis.normalized()).toRotationMatrix();
  return R * p + tau * velocity;
}

/// The simulated shutter: the row y whose camera (time readout ((y + 0.5) / h - 0.5)) images p
/// in row y, found by bisection on the row's residual (monotonic for a rate well under the row
/// sweep), and the pixel it gives.
std::optional<Eigen::Vector2d> simulatedPixel(const CameraModel& global,
                                              const Eigen::Vector3d& rate,
                                              const Eigen::Vector3d& velocity, double readout,
                                              const Eigen::Vector3d& p) {
  const int h = global.height();
  auto residual = [&](double y) -> std::optional<double> {
    const auto px = global.project(moved(rate, velocity, readout * ((y + 0.5) / h - 0.5), p));
    if (!px) return std::nullopt;
    return px->y() - y;
  };
  double lo = -0.5, hi = h - 0.5;
  const auto r_lo = residual(lo), r_hi = residual(hi);
  if (!r_lo || !r_hi || (*r_lo > 0) == (*r_hi > 0)) return std::nullopt;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    const auto r = residual(mid);
    if (!r) return std::nullopt;
    ((*r > 0) == (*r_lo > 0) ? lo : hi) = mid;
  }
  const double y = 0.5 * (lo + hi);
  return global.project(moved(rate, velocity, readout * ((y + 0.5) / h - 0.5), p));
}

TEST(RollingShutterCamera, AgreesWithASimulatedShutterOverTheImage) {
  const double readout = 0.03;
  const std::shared_ptr<const CameraModel> global = makeCameraModel(rollingShutterVga(readout));
  // A hand-held pan at 150 deg/s about a tilted axis (~40 px of skew over the image), the camera
  // moving at 1 m/s.
  const Eigen::Vector3d rate = 150.0 * M_PI / 180.0 * Eigen::Vector3d(0.2, 1.0, 0.1).normalized();
  const Eigen::Vector3d velocity = Eigen::Vector3d(0.9, 0.1, 0.4).normalized();
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.55, 0.55), depth(0.5, 8.0);
  int checked = 0;
  double largest_skew = 0.0, largest_ray_error = 0.0;
  for (int i = 0; i < 400; ++i) {
    const Eigen::Vector3d p = Eigen::Vector3d(u(rng), 0.75 * u(rng), 1.0) * depth(rng);
    const auto truth = simulatedPixel(*global, rate, velocity, readout, p);
    if (!truth || !global->isInImage(*truth)) continue;
    // The depth the ray needs is the point's in the camera of its row's time.
    const double tau = readout * ((truth->y() + 0.5) / global->height() - 0.5);
    const RollingShutterCamera camera(global, rate, velocity, moved(rate, velocity, tau, p).z());
    const auto pixel = camera.project(p);
    ASSERT_TRUE(pixel.has_value());
    EXPECT_LT((*pixel - *truth).norm(), 1e-3) << p.transpose();
    // At the point's own depth, the ray of its pixel is its direction in the stamp's camera.
    EXPECT_LT(std::acos(std::min(1.0, camera.unproject(*truth).dot(p.normalized()))), 2e-6);
    // At a scene depth of 2 m, the translation's share is off by tau v (1/z - 1/2).
    const RollingShutterCamera at_scene_depth(global, rate, velocity, 2.0);
    const double ray_error =
        std::acos(std::min(1.0, at_scene_depth.unproject(*truth).dot(p.normalized())));
    EXPECT_LT(ray_error, 1.2 * std::abs(tau) * std::abs(1.0 / p.z() - 0.5) + 2e-6);
    largest_ray_error = std::max(largest_ray_error, ray_error);
    largest_skew = std::max(largest_skew, (*truth - *global->project(p)).norm());
    ++checked;
  }
  EXPECT_GT(checked, 250);
  EXPECT_GT(largest_skew, 15.0);       // what a global-shutter model would be wrong by
  EXPECT_GT(largest_ray_error, 1e-3);  // the bound above is not empty
}

TEST(RollingShutterCamera, ProjectionJacobianMatchesNumericDerivativeAlongTheRow) {
  const std::shared_ptr<const CameraModel> global = makeCameraModel(rollingShutterVga(0.02));
  const RollingShutterCamera camera(global, Eigen::Vector3d(0.3, 2.0, -0.2),
                                    Eigen::Vector3d(0.5, 0.0, 1.0));
  const Eigen::Vector3d p(0.4, -0.3, 2.0);
  const Eigen::Matrix<double, 2, 3> J = camera.projectionJacobian(p);
  // The Jacobian leaves out the row's own change with the point (~rate x readout x f / h of it).
  for (int k = 0; k < 3; ++k) {
    Eigen::Vector3d d = Eigen::Vector3d::Zero();
    d[k] = 1e-6;
    const Eigen::Vector2d numeric = (*camera.project(p + d) - *camera.project(p - d)) / 2e-6;
    EXPECT_LT((J.col(k) - numeric).norm(), 0.06 * numeric.norm() + 0.5) << k;
  }
}

TEST(RollingShutterCamera, APointFarOutsideTheFrameStaysOutside) {
  // A point beside the camera, almost in its image plane, projects ~40 000 px off the image; the
  // row "time" of such a pixel is over a second away from the frame's, and a panning camera's
  // rotation over that time would bring the point into view. Found in a 150 deg/s pan (office_pan
  // with a 20 ms readout): such a point of the local map was matched inside the image, and its
  // 49 000 px residual turned the motion-only BA 4 degrees away, losing 3-94 frames. Rows beyond
  // the frame are seen from the camera of the nearest row, so such a point stays where it is.
  const auto global = makeCameraModel(rollingShutterVga(0.0));
  const auto rolling = frameCamera(makeCameraModel(rollingShutterVga(0.02)),
                                   Eigen::Vector3d(0.0, 1.6, 0.5), Eigen::Vector3d(0.1, 0, 0), 2.0);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> side(-1.5, 1.5), depth(0.005, 0.3);
  int outside = 0;
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector3d p(side(rng), side(rng), depth(rng));
    const auto far = global->project(p);
    if (far && global->isInImage(*far, -200.0)) continue;  // within 200 px of the image
    ++outside;
    const auto px = rolling->project(p);
    EXPECT_FALSE(px && rolling->isInImage(*px)) << p.transpose() << " -> " << px->transpose();
  }
  EXPECT_GT(outside, 1000);
  // The case the pan met, exactly.
  const auto seen = rolling->project(Eigen::Vector3d(-1.364, 0.891, 0.017));
  EXPECT_FALSE(seen && rolling->isInImage(*seen));
}

TEST(RollingShutterCamera, AGlobalShutterOrAStillCameraIsTheCameraItself) {
  const std::shared_ptr<const CameraModel> global = makeCameraModel(rollingShutterVga(0.0));
  const Eigen::Vector3d moving(0.5, 0.0, 0.0);
  EXPECT_EQ(frameCamera(global, Eigen::Vector3d(0.0, 3.0, 0.0), moving, 2.0), global);
  const std::shared_ptr<const CameraModel> rolling = makeCameraModel(rollingShutterVga(0.03));
  const std::shared_ptr<const CameraModel> still =
      frameCamera(rolling, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 2.0);
  const Eigen::Vector3d p(0.3, 0.2, 1.5);
  EXPECT_LT((*still->project(p) - *rolling->project(p)).norm(), 1e-12);
  EXPECT_EQ(frameCamera(rolling, Eigen::Vector3d(NAN, 0.0, 0.0), moving, 2.0), rolling);
  EXPECT_EQ(frameCamera(rolling, Eigen::Vector3d::Zero(), moving, 0.0), rolling);
  // Turning only: the same as a zero velocity (at any scene depth), the camera itself for a
  // global shutter.
  const Eigen::Vector3d rate(0.2, -2.5, 0.1);
  const auto turning = turningFrameCamera(rolling, rate);
  const auto zero_velocity = frameCamera(rolling, rate, Eigen::Vector3d::Zero(), 7.0);
  EXPECT_LT((*turning->project(p) - *zero_velocity->project(p)).norm(), 1e-12);
  const Eigen::Vector2d top_row(600.0, 3.0);
  EXPECT_LT((turning->unproject(top_row) - zero_velocity->unproject(top_row)).norm(), 1e-12);
  EXPECT_GT((turning->unproject(top_row) - rolling->unproject(top_row)).norm(), 1e-3);
  EXPECT_EQ(turningFrameCamera(global, rate), global);
}

TEST(RollingShutterCamera, AnImpossibleReadoutIsRefusedWithAReason) {
  for (const double readout : {-0.01, 1.5, static_cast<double>(NAN)}) {
    try {
      rollingShutterVga(readout).validate();
      ADD_FAILURE() << readout;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("rolling_shutter_readout_s"), std::string::npos);
    }
  }
}

}  // namespace
}  // namespace scale_drift_slam::geometry
