// The keyframe rule: distance to the closest keyframe against a fraction of the scene depth.

#include <gtest/gtest.h>

#include "scale_drift_slam/tracking/keyframe_rule.h"

namespace scale_drift_slam::tracking {
namespace {

TEST(KeyframeRule, DropsWhenFarFromEveryKeyframeRelativeToTheSceneDepth) {
  const std::vector<std::pair<map::KeyframeId, Eigen::Vector3d>> keyframes = {
      {1, Eigen::Vector3d(0, 0, 0)}, {2, Eigen::Vector3d(1, 0, 0)}, {3, Eigen::Vector3d(2, 0, 0)}};
  KeyframeRuleParams params;
  params.distance_to_depth_ratio = 0.1;
  // 0.4 from keyframe 3; depth 5 -> threshold 0.5: keep; depth 3 -> threshold 0.3: drop.
  KeyframeDecision d = decideKeyframe(Eigen::Vector3d(2.4, 0, 0), keyframes, 5.0, params);
  EXPECT_FALSE(d.drop);
  EXPECT_EQ(d.closest, 3u);
  EXPECT_NEAR(d.distance, 0.4, 1e-12);
  EXPECT_NEAR(d.threshold, 0.5, 1e-12);
  d = decideKeyframe(Eigen::Vector3d(2.4, 0, 0), keyframes, 3.0, params);
  EXPECT_TRUE(d.drop);
  // The same motion in a map at twice the scale (scale drift) gives the same decision.
  std::vector<std::pair<map::KeyframeId, Eigen::Vector3d>> doubled = keyframes;
  for (auto& kf : doubled)
    kf.second *= 2.0;
  EXPECT_TRUE(decideKeyframe(Eigen::Vector3d(4.8, 0, 0), doubled, 6.0, params).drop);
  EXPECT_TRUE(decideKeyframe(Eigen::Vector3d(0, 0, 0), {}, 1.0, params).drop);
  EXPECT_THROW(decideKeyframe(Eigen::Vector3d(0, 0, 0), keyframes, 0.0, params),
               std::invalid_argument);
}

TEST(KeyframeRule, DropsEarlierWhenTheViewLeavesTheMappedPoints) {
  const std::vector<std::pair<map::KeyframeId, Eigen::Vector3d>> keyframes = {
      {3, Eigen::Vector3d(0, 0, 0)}};
  KeyframeRuleParams params;
  params.distance_to_depth_ratio = 0.1;  // threshold 0.4 at depth 4
  params.min_tracked_ratio = 0.5;
  params.min_distance_fraction = 0.25;  // at least 0.1 from the keyframe
  const Eigen::Vector3d moved(0.2, 0, 0);
  // Half the points gone: drop, though the distance rule alone would wait.
  KeyframeDecision d = decideKeyframe(moved, keyframes, 4.0, params, TrackedPoints{99, 200});
  EXPECT_TRUE(d.drop);
  EXPECT_TRUE(d.view_leaving_map);
  EXPECT_FALSE(decideKeyframe(moved, keyframes, 4.0, params, TrackedPoints{101, 200}).drop);
  EXPECT_FALSE(decideKeyframe(moved, keyframes, 4.0, params).drop);
  // Too close to the keyframe for new points to have parallax: wait.
  EXPECT_FALSE(
      decideKeyframe(Eigen::Vector3d(0.05, 0, 0), keyframes, 4.0, params, TrackedPoints{20, 200})
          .drop);
  // Ratio 0 switches the addition off.
  params.min_tracked_ratio = 0.0;
  EXPECT_FALSE(decideKeyframe(moved, keyframes, 4.0, params, TrackedPoints{1, 200}).drop);
  params.min_tracked_ratio = 1.5;
  EXPECT_THROW(params.validate(), std::invalid_argument);
}

TEST(KeyframeRule, MedianSceneDepthIgnoresPointsBehindTheCamera) {
  const geometry::SE3 T(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, 1));
  EXPECT_NEAR(medianSceneDepth(T, {{0, 0, 1}, {0, 0, 2}, {0, 0, 3}, {0, 0, -5}}), 3.0, 1e-12);
  EXPECT_THROW(medianSceneDepth(T, {{0, 0, -3}}), std::invalid_argument);
}

}  // namespace
}  // namespace scale_drift_slam::tracking
