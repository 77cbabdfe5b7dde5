// New features and the motion prior on rendered views of a textured wall with known geometry:
// candidates started at a keyframe, carried by the flow and filtered with the true poses, are
// promoted at a later keyframe onto the wall, also when some frames in between had no pose (they
// only follow the flow); the flow-based prior recovers the true motion far better than the
// constant-velocity guess, and falls back to the guess with a wide uncertainty when there is
// nothing to flow.

#include <gtest/gtest.h>

#include "scale_drift_slam/geometry/so3.h"
#include "scale_drift_slam/tracking/feature_candidates.h"
#include "scale_drift_slam/tracking/motion_prior.h"
#include "synthetic_images.h"

namespace scale_drift_slam::tracking {
namespace {

constexpr double kWallDepth = 3.0;

std::shared_ptr<const geometry::CameraModel> camera() {
  return test::pinholeCamera(500.0);
}

test::TexturedPlane wall() {
  test::TexturedPlane p;
  p.texture = test::texturedImage(2000, 1400, 51);
  p.origin = Eigen::Vector3d(0, 0, kWallDepth);
  p.axis_u = Eigen::Vector3d(1, 0, 0);
  p.axis_v = Eigen::Vector3d(0, 1, 0);
  p.metres_per_pixel = 0.004;
  return p;
}

// Frame k: 2 cm per frame sideways with a slight turn (T_cam_world).
geometry::SE3 pose(int k) {
  return geometry::SE3(geometry::expSO3(Eigen::Vector3d(0, 0.002 * k, 0)),
                       Eigen::Vector3d(0.02 * k, 0.003 * k, 0))
      .inverse();
}

features::ImagePyramid render(int k) {
  return features::buildPyramid(test::renderPlanes({wall()}, camera()->K(), pose(k), 640, 480), 4,
                                15);
}

/// Candidates spawned at keyframe 0 (frame 0), carried by the flow through frames 1-12 and
/// updated with the true pose except on frames `without_pose` (there they only follow the flow),
/// promoted at keyframe 1 (frame 12): 24 cm of baseline at 3 m, 4.6 degrees of parallax.
std::vector<PromotedFeature> promoteAfterTwelveFrames(int first_without_pose = 0,
                                                      int last_without_pose = -1) {
  const auto cam = camera();
  FeatureCandidates candidates(FeatureCandidateParams{}, features::FeatureDetectionParams{}, 500.0);
  features::ImagePyramid previous = render(0);
  EXPECT_GT(candidates.spawn(0, pose(0), previous, {}, kWallDepth, *cam), 100);
  OpticalFlow flow(OpticalFlowParams{});
  for (int k = 1; k <= 12; ++k) {
    const features::ImagePyramid current = render(k);
    std::vector<cv::Point2f> tracked;
    std::vector<unsigned char> ok;
    flow.track(previous, current, candidates.pixels(), &tracked, &ok);
    if (k >= first_without_pose && k <= last_without_pose) {
      candidates.follow(tracked, ok, *cam);
      std::vector<cv::Point2f> kept;
      for (std::size_t i = 0; i < tracked.size(); ++i)
        if (ok[i]) kept.push_back(tracked[i]);
      EXPECT_EQ(candidates.pixels(), kept);  // moved to where the flow found them
    } else {
      candidates.update(tracked, ok, pose(k), *cam);
    }
    previous = current;
  }
  return candidates.promote(1, pose(12));
}

int onTheWall(const std::vector<PromotedFeature>& promoted) {
  int on_wall = 0;
  for (const PromotedFeature& f : promoted)
    on_wall += std::abs(f.p_world.z() - kWallDepth) < 0.03 * kWallDepth;
  return on_wall;
}

TEST(FeatureCandidates, PromotesFilteredFeaturesOntoTheWall) {
  const std::vector<PromotedFeature> promoted = promoteAfterTwelveFrames();
  ASSERT_GT(promoted.size(), 80u);
  for (const PromotedFeature& f : promoted) {
    EXPECT_EQ(f.origin, 0u);
    EXPECT_EQ(f.views.front().keyframe_id, 0u);
    EXPECT_EQ(f.views.back().keyframe_id, 1u);
  }
  EXPECT_GT(onTheWall(promoted), 0.95 * promoted.size());
}

TEST(FeatureCandidates, FollowTheFlowThroughFramesWithoutAPose) {
  // Frames 5-8 have no pose (tracking lost): the candidates only follow the flow, so that the
  // flow of frame 9 starts where they are; filtered again from frame 9 on, they still land on
  // the wall.
  const std::vector<PromotedFeature> promoted = promoteAfterTwelveFrames(5, 8);
  ASSERT_GT(promoted.size(), 80u);
  EXPECT_GT(onTheWall(promoted), 0.95 * promoted.size());
}

TEST(MotionPrior, FlowRecoversTheMotion) {
  const auto cam = camera();
  MotionPriorEstimator estimator(MotionPriorParams{}, features::MotionOnlyBundleAdjustmentParams{});
  const features::ImagePyramid previous = render(0), current = render(3);
  std::vector<FlowSeed> seeds;
  for (const cv::KeyPoint& k : features::detectSpreadCorners(previous.base(), 200, {})) {
    const Eigen::Vector3d ray = cam->unproject(Eigen::Vector2d(k.pt.x, k.pt.y));
    seeds.push_back({k.pt, pose(0).inverse() * (ray * (kWallDepth / ray.z()))});
  }
  std::vector<cv::Point2f> extra_tracked;
  std::vector<unsigned char> extra_ok;
  const geometry::SE3 guess = pose(1);  // two frames behind
  const MotionPrior prior =
      estimator.estimate(previous, current, seeds, {cv::Point2f(300, 200)}, guess, pose(0),
                         kWallDepth, *cam, &extra_tracked, &extra_ok);
  ASSERT_TRUE(prior.from_flow);
  EXPECT_GT(prior.num_tracks, 100);
  ASSERT_EQ(extra_tracked.size(), 1u);
  EXPECT_TRUE(extra_ok[0]);
  const Eigen::Matrix<double, 6, 1> error = (pose(3) * prior.T_cur_world.inverse()).log();
  EXPECT_LT(error.norm(), 0.002);
  EXPECT_LT(error.norm(), 0.1 * (pose(3) * guess.inverse()).log().norm());
  // The truth lies inside the prior's uncertainty (chi2 with 6 dof, 99.9%: 22.5).
  EXPECT_LT(error.dot(prior.Sigma.inverse() * error), 22.5);

  const MotionPrior fallback = estimator.estimate(previous, current, {}, {}, guess, pose(0),
                                                  kWallDepth, *cam, &extra_tracked, &extra_ok);
  EXPECT_FALSE(fallback.from_flow);
  EXPECT_LT((fallback.T_cur_world.translation() - guess.translation()).norm(), 1e-12);
  EXPECT_GT(fallback.Sigma(3, 3), 100 * prior.Sigma(3, 3));
}

}  // namespace
}  // namespace scale_drift_slam::tracking
