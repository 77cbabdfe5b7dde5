// Map initialisation on rendered image sequences with a known answer: a planar scene (one
// textured wall) and a two-plane scene (either model) both initialise with the right motion and
// median depth 1; a purely rotating camera never initialises; a black frame or a blank one does
// no harm.

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
                  const geometry::SE3& truth_k) {
  ASSERT_TRUE(run.map.has_value());
  const geometry::SE3 truth = truth_k * truth_first.inverse();
  const double rotation_error =
      geometry::logSO3(run.map->T_second_first.rotation() * truth.rotation().conjugate()).norm();
  EXPECT_LT(rotation_error * 180 / M_PI, 0.3);
  const double direction_error = std::acos(std::clamp(
      run.map->T_second_first.translation().normalized().dot(truth.translation().normalized()),
      -1.0, 1.0));
  EXPECT_LT(direction_error * 180 / M_PI, 3.0);
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
