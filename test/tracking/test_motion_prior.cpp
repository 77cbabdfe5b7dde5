// Carrying measured map points through a run of frames (MotionPriorEstimator::carry, used when a
// relocalisation answer arrives a few frames after the frame it was asked for): frame-to-frame
// flow through rendered views of a textured room, then the pose at the last frame. The carried
// pixels lie where the true pose projects the points, and the pose is the true one.

#include <random>

#include <gtest/gtest.h>

#include "scale_drift_slam/geometry/so3.h"
#include "scale_drift_slam/tracking/motion_prior.h"
#include "synthetic_images.h"

namespace scale_drift_slam::tracking {
namespace {

/// Frame k of a fast sideways move (8 cm and 0.6 degrees of yaw per frame) in front of the far
/// wall of boxRoom(4, 2, 4): T_world_cam.
geometry::SE3 fastPose(int k) {
  return geometry::SE3(geometry::expSO3(Eigen::Vector3d(0.0, 0.01 * k, 0.0)),
                       Eigen::Vector3d(-0.3 + 0.08 * k, 0.05, -1.0));
}

TEST(MotionPrior, CarriesPointsThroughFramesToTheTruePose) {
  const auto room = test::boxRoom(4.0, 2.0, 4.0, 40);
  const auto camera = test::pinholeCamera(450.0);
  std::vector<features::ImagePyramid> frames;
  for (int k = 0; k <= 6; ++k) {
    frames.push_back(features::buildPyramid(
        test::renderPlanes(room, camera->K(), fastPose(k).inverse(), 640, 480), 4, 15));
  }
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> x(-3.0, 3.0), y(-1.5, 1.5);
  std::vector<FlowSeed> seeds;
  while (seeds.size() < 150) {
    const Eigen::Vector3d p_world(x(rng), y(rng), 4.0);
    const auto px = camera->project(fastPose(0).inverse() * p_world);
    if (px && camera->isInImage(*px, 20.0)) {
      seeds.push_back(
          {cv::Point2f(static_cast<float>(px->x()), static_cast<float>(px->y())), p_world});
    }
  }
  MotionPriorEstimator estimator{MotionPriorParams{}, features::MotionOnlyBundleAdjustmentParams{}};
  const auto carried = estimator.carry(frames, seeds, fastPose(0).inverse(), *camera);
  ASSERT_TRUE(carried.has_value());
  EXPECT_GT(carried->px.size(), 120u);  // most survive six frames of 9-10 px motion each
  const geometry::SE3 T_true = fastPose(6).inverse();
  EXPECT_LT((carried->T_cam_world.inverseTranslation() - fastPose(6).translation()).norm(), 0.01);
  EXPECT_LT((carried->T_cam_world * T_true.inverse()).log().head<3>().norm(), 0.003);
  double worst = 0.0;
  for (std::size_t i = 0; i < carried->px.size(); ++i) {
    const Eigen::Vector2d truth = *camera->project(T_true * seeds[carried->seed[i]].p_world);
    worst = std::max(worst, (Eigen::Vector2d(carried->px[i].x, carried->px[i].y) - truth).norm());
  }
  EXPECT_LT(worst, 1.5);

  // One frame: nothing to carry, the seeds as they are. Too few seeds: nothing.
  const auto same = estimator.carry({frames[0]}, seeds, fastPose(0).inverse(), *camera);
  ASSERT_TRUE(same.has_value());
  EXPECT_EQ(same->px.size(), seeds.size());
  const std::vector<FlowSeed> few(seeds.begin(), seeds.begin() + 5);
  EXPECT_FALSE(estimator.carry(frames, few, fastPose(0).inverse(), *camera).has_value());
}

}  // namespace
}  // namespace scale_drift_slam::tracking
