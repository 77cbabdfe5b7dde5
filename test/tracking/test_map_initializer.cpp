// Map initialisation on rendered image sequences with a known answer: a planar scene (one
// textured wall) and a two-plane scene (either model) both initialise with the right motion and
// median depth 1; a purely rotating camera never initialises; a rolling shutter's pan starting
// gives the motion a global shutter would; a black frame or a blank one does no harm.

#include <functional>

#include <gtest/gtest.h>

#include "scale_drift_slam/geometry/so3.h"
#include "scale_drift_slam/tracking/map_initializer.h"
#include "synthetic_images.h"

namespace scale_drift_slam::tracking {
namespace {

constexpr int kWidth = 640, kHeight = 480;

std::shared_ptr<const geometry::CameraModel> camera() {
  return test::pinholeCamera(500.0);
}

test::TexturedPlane wall(double depth, double tilt, unsigned seed, int w, int h) {
  test::TexturedPlane p;
  p.texture = test::texturedImage(w, h, seed);
  p.origin = Eigen::Vector3d(0, 0, depth);
  p.axis_u = Eigen::Vector3d(std::cos(tilt), 0, std::sin(tilt));
  p.axis_v = Eigen::Vector3d(0, 1, 0);
  p.metres_per_pixel = 0.006;
  return p;
}

// Camera k of a sideways motion: world -> camera.
geometry::SE3 sideways(int k, double step, double yaw_step) {
  const geometry::SE3 T_world_cam(geometry::expSO3(Eigen::Vector3d(0, yaw_step * k, 0)),
                                  Eigen::Vector3d(step * k, 0.2 * step * k, 0));
  return T_world_cam.inverse();
}

struct InitRun {
  std::optional<InitialMap> map;
  int frame = -1;
};

InitRun runSequence(const std::vector<test::TexturedPlane>& planes,
                    const std::function<geometry::SE3(int)>& pose, int frames) {
  MapInitializer initializer(camera(), InitializerParams{}, features::FeatureDetectionParams{});
  const Eigen::Matrix3d K = camera()->K();
  InitRun run;
  for (int k = 0; k < frames && !run.map; ++k) {
    const cv::Mat image = test::renderPlanes(planes, K, pose(k), kWidth, kHeight);
    run.map = initializer.addFrame(0.1 * k, features::buildPyramid(image, 4));
    run.frame = k;
  }
  return run;
}

void expectMotion(const InitRun& run, const geometry::SE3& truth_first,
                  const geometry::SE3& truth_k, double max_rotation_deg = 0.3,
                  double max_direction_deg = 3.0) {
  ASSERT_TRUE(run.map.has_value());
  const geometry::SE3 truth = truth_k * truth_first.inverse();
  const double rotation_error =
      geometry::logSO3(run.map->T_second_first.rotation() * truth.rotation().conjugate()).norm();
  EXPECT_LT(rotation_error * 180 / M_PI, max_rotation_deg);
  const double direction_error = std::acos(std::clamp(
      run.map->T_second_first.translation().normalized().dot(truth.translation().normalized()),
      -1.0, 1.0));
  EXPECT_LT(direction_error * 180 / M_PI, max_direction_deg);
  std::vector<double> depths;
  for (std::size_t i = 0; i < run.map->p_first.size(); ++i) {
    if (run.map->triangulated[i]) depths.push_back(run.map->p_first[i].z());
  }
  ASSERT_GT(depths.size(), 100u);
  std::nth_element(depths.begin(), depths.begin() + depths.size() / 2, depths.end());
  EXPECT_NEAR(depths[depths.size() / 2], 1.0, 1e-9);
}

TEST(MapInitializer, InitialisesOnAPlanarScene) {
  const std::vector<test::TexturedPlane> planes = {wall(3.0, 0.3, 11, 1400, 1000)};
  const auto pose = [](int k) { return sideways(k, 0.02, 0.002); };
  const InitRun run = runSequence(planes, pose, 40);
  ASSERT_TRUE(run.map.has_value());
  EXPECT_TRUE(run.map->used_homography);
  expectMotion(run, pose(0), pose(run.frame));
}

TEST(MapInitializer, InitialisesOnATwoPlaneScene) {
  test::TexturedPlane near = wall(1.8, -0.2, 13, 300, 500);
  near.origin.x() = 0.3;
  const std::vector<test::TexturedPlane> planes = {wall(4.0, 0.0, 12, 1600, 1200), near};
  const auto pose = [](int k) { return sideways(k, 0.02, -0.002); };
  const InitRun run = runSequence(planes, pose, 40);
  ASSERT_TRUE(run.map.has_value());
  // The big far wall can make the homography the better model; the near plane then tells its two
  // motions apart (frame 15; waiting for the essential matrix took until frame 17).
  EXPECT_LE(run.frame, 17);
  expectMotion(run, pose(0), pose(run.frame));
}

TEST(MapInitializer, RefusesPureRotation) {
  const std::vector<test::TexturedPlane> planes = {wall(3.0, 0.0, 14, 2400, 1400)};
  const auto pose = [](int k) {
    return geometry::SE3(geometry::expSO3(Eigen::Vector3d(0.0005 * k, 0.008 * k, 0)),
                         Eigen::Vector3d::Zero());
  };
  const InitRun run = runSequence(planes, pose, 60);
  EXPECT_FALSE(run.map.has_value());
}

// A rolling shutter's frame: band by band, each row seen from the camera of its own time
// (geometry::RollingShutterCamera's convention: row y at readout x ((y + 0.5) / height - 0.5)
// after the stamp).
cv::Mat renderRollingShutter(const std::vector<test::TexturedPlane>& planes,
                             const Eigen::Matrix3d& K,
                             const std::function<geometry::SE3(double)>& T_cam_world_at,
                             double stamp, double readout, int bands) {
  cv::Mat image(kHeight, kWidth, CV_8UC1);
  for (int b = 0; b < bands; ++b) {
    const int y0 = b * kHeight / bands, y1 = (b + 1) * kHeight / bands;
    const double tau = readout * ((0.5 * (y0 + y1) + 0.5) / kHeight - 0.5);
    const cv::Mat band =
        test::renderPlanes(planes, K, T_cam_world_at(stamp + tau), kWidth, kHeight);
    band.rowRange(y0, y1).copyTo(image.rowRange(y0, y1));
  }
  return image;
}

TEST(MapInitializer, MeasuresARollingShutterPanAsAGlobalShutter) {
  // A hand-held pan starting, seen through a 30 ms readout: the yaw rate grows by 7.5 rad/s^2
  // (0.5 rad/s and 8 px of image motion a frame at 30 Hz after 2 frames, 1.5 rad/s after 6), with
  // 0.3 m/s sideways. The initializer waits for 60 px of motion, so its first view is still and
  // its second sheared by ~20 px from the top row to the bottom one: the two are bent unlike
  // each other. Each is measured as a global shutter would see it at its stamp, from the
  // rotation rate its frame-to-frame tracks show.
  geometry::CameraCalibration calibration = camera()->calibration();
  calibration.rolling_shutter_readout_s = 0.03;
  const std::shared_ptr<const geometry::CameraModel> rolling =
      geometry::makeCameraModel(calibration);
  test::TexturedPlane near = wall(2.0, -0.2, 16, 500, 700);
  near.origin.x() = 0.6;
  const std::vector<test::TexturedPlane> planes = {wall(4.0, 0.0, 15, 1800, 1300), near};
  const auto T_cam_world_at = [](double t) {
    return geometry::SE3(geometry::expSO3(Eigen::Vector3d(0, 0.5 * 7.5 * t * t, 0)),
                         Eigen::Vector3d(0.3 * t, 0, 0))
        .inverse();
  };
  InitializerParams params;
  params.min_disparity_px = 60.0;
  MapInitializer initializer(rolling, params, features::FeatureDetectionParams{});
  InitRun run;
  for (int k = 0; k < 20 && !run.map; ++k) {
    const double stamp = k / 30.0;
    const cv::Mat image =
        renderRollingShutter(planes, rolling->K(), T_cam_world_at, stamp, 0.03, 24);
    run.map = initializer.addFrame(stamp, features::buildPyramid(image, 4));
    run.frame = k;
  }
  ASSERT_TRUE(run.map.has_value()) << initializer.status();
  // As accurate as a global shutter on the same motion (0.01 deg of rotation and 0.29 deg of
  // direction off); taken as a global shutter, these views start the map a frame later with 0.15
  // and 0.94 deg.
  expectMotion(run, T_cam_world_at(run.map->first_timestamp), T_cam_world_at(run.frame / 30.0),
               0.08, 0.5);
  // The tracker measures the second keyframe's new corners with the camera the initializer
  // measured that view with: a point seen on any row lands where a global shutter at the stamp
  // would see it.
  ASSERT_TRUE(run.map->second_camera);
  const double stamp = run.frame / 30.0;
  double worst_measured = 0.0, worst_plain = 0.0;
  for (double x = -1.5; x <= 1.5; x += 0.5) {
    for (double y = -1.0; y <= 1.0; y += 0.5) {
      const Eigen::Vector3d p_world(x + 0.3 * stamp, y, 4.0);
      const std::optional<Eigen::Vector2d> global =
          rolling->project(T_cam_world_at(stamp) * p_world);
      if (!global) continue;
      Eigen::Vector2d px = *global;  // the row's time depends on where the point lands
      for (int i = 0; i < 5; ++i) {
        const double tau = 0.03 * ((px.y() + 0.5) / kHeight - 0.5);
        px = rolling->project(T_cam_world_at(stamp + tau) * p_world).value_or(px);
      }
      if (px.y() < 0 || px.y() >= kHeight || px.x() < 0 || px.x() >= kWidth) continue;
      const Eigen::Vector2d xy = rolling->undistortToNormalized(*global);
      const double f = rolling->calibration().meanFocalLength();
      worst_measured = std::max(
          worst_measured, f * (run.map->second_camera->undistortToNormalized(px) - xy).norm());
      worst_plain = std::max(worst_plain, f * (rolling->undistortToNormalized(px) - xy).norm());
    }
  }
  EXPECT_LT(worst_measured, 1.0);
  EXPECT_GT(worst_plain, 5.0);
}

TEST(MapInitializer, SurvivesBlackAndBlankFrames) {
  MapInitializer initializer(camera(), InitializerParams{}, features::FeatureDetectionParams{});
  for (int k = 0; k < 5; ++k) {
    EXPECT_FALSE(initializer.addFrame(
        k, features::buildPyramid(cv::Mat::zeros(kHeight, kWidth, CV_8UC1), 4)));
    EXPECT_FALSE(initializer.status().empty());
  }
  EXPECT_FALSE(initializer.addFrame(
      9, features::buildPyramid(cv::Mat(kHeight, kWidth, CV_8UC1, cv::Scalar(200)), 4)));
}

}  // namespace
}  // namespace scale_drift_slam::tracking
