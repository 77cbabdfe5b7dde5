// The keyframe rule: distance to the closest keyframe against a fraction of the scene depth.

#include <cmath>

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
  // Ratio 0 and no minimum count switch the addition off.
  params.min_tracked_ratio = 0.0;
  params.min_tracked_points = 0;
  EXPECT_FALSE(decideKeyframe(moved, keyframes, 4.0, params, TrackedPoints{1, 200}).drop);
  params.min_tracked_ratio = 1.5;
  EXPECT_THROW(params.validate(), std::invalid_argument);
}

TEST(KeyframeRule, DropsWhenTheMapIsStarvingWhateverTheLastKeyframeHad) {
  // An open crossing: the last keyframe tracked only 40 points (already starved), 30 now: the
  // ratio rule would wait for 20; below 50 points a keyframe is due once there is parallax.
  const std::vector<std::pair<map::KeyframeId, Eigen::Vector3d>> keyframes = {
      {3, Eigen::Vector3d(0, 0, 0)}};
  KeyframeRuleParams params;
  params.min_tracked_points = 50;
  const Eigen::Vector3d moved(0.2, 0, 0);  // threshold 0.4 at depth 4, parallax from 0.1
  KeyframeDecision d = decideKeyframe(moved, keyframes, 4.0, params, TrackedPoints{30, 40});
  EXPECT_TRUE(d.drop);
  EXPECT_TRUE(d.view_leaving_map);
  EXPECT_FALSE(decideKeyframe(moved, keyframes, 4.0, params, TrackedPoints{60, 40}).drop);
  EXPECT_FALSE(  // no parallax yet
      decideKeyframe(Eigen::Vector3d(0.05, 0, 0), keyframes, 4.0, params, TrackedPoints{30, 40})
          .drop);
  params.min_tracked_points = -1;
  EXPECT_THROW(params.validate(), std::invalid_argument);
}

TEST(KeyframeRule, DropsWhenCertainNewFeaturesGiveTheParallax) {
  const std::vector<std::pair<map::KeyframeId, Eigen::Vector3d>> keyframes = {
      {3, Eigen::Vector3d(0, 0, 0)}};
  KeyframeRuleParams params;  // threshold 0.4 at depth 4, parallax from 0.1
  params.min_certain_candidates = 40;
  const Eigen::Vector3d close(0.05, 0, 0);
  // Too close for the distance, but 40 new features have certain depths: their parallax is there.
  KeyframeDecision d = decideKeyframe(close, keyframes, 4.0, params, TrackedPoints{20, 200, 40});
  EXPECT_TRUE(d.drop);
  EXPECT_TRUE(d.view_leaving_map);
  EXPECT_FALSE(decideKeyframe(close, keyframes, 4.0, params, TrackedPoints{20, 200, 39}).drop);
  params.min_certain_candidates = 0;  // the distance alone
  EXPECT_FALSE(decideKeyframe(close, keyframes, 4.0, params, TrackedPoints{20, 200, 400}).drop);
  params.min_certain_candidates = -1;
  EXPECT_THROW(params.validate(), std::invalid_argument);
}

TEST(KeyframeRule, DropsWhenTheViewTurnedAwayFromTheNearbyKeyframes) {
  const std::vector<std::pair<map::KeyframeId, Eigen::Vector3d>> keyframes = {
      {3, Eigen::Vector3d(0, 0, 0)}, {4, Eigen::Vector3d(5, 0, 0)}};
  KeyframeRuleParams params;  // threshold 0.4 at depth 4, parallax from 0.1
  params.max_view_turn_fraction = 0.25;
  const double fov = 1.0;  // rad: turns beyond 0.25 rad are not covered
  const Eigen::Vector3d moved(0.2, 0, 0);
  const Eigen::Vector3d turned(std::sin(0.3), 0, std::cos(0.3));
  // Keyframe 4 looks the same way but is far away: it does not cover the view.
  ViewDirections view{turned, {Eigen::Vector3d::UnitZ(), turned}, fov};
  KeyframeDecision d = decideKeyframe(moved, keyframes, 4.0, params, TrackedPoints{200, 200}, view);
  EXPECT_TRUE(d.drop);
  EXPECT_TRUE(d.view_turned);
  // A small turn is covered by keyframe 3.
  view.current = Eigen::Vector3d(std::sin(0.2), 0, std::cos(0.2));
  EXPECT_FALSE(decideKeyframe(moved, keyframes, 4.0, params, TrackedPoints{200, 200}, view).drop);
  // Fraction 0 switches it off; one direction per keyframe is required.
  params.max_view_turn_fraction = 0.0;
  EXPECT_FALSE(decideKeyframe(moved, keyframes, 4.0, params, TrackedPoints{200, 200}, view).drop);
  params.max_view_turn_fraction = 0.25;
  view.keyframes.pop_back();
  EXPECT_THROW(decideKeyframe(moved, keyframes, 4.0, params, TrackedPoints{200, 200}, view),
               std::invalid_argument);
}

TEST(KeyframeRule, AViewThatTurnedAwayDropsWithoutBaseline) {
  // A hand-held pan: the camera turns faster than it moves, and the map points leave the view
  // before the baseline comes. A turned view drops a keyframe anyway, so that new features are
  // spawned where the view went, with its map still well fed or starving.
  const std::vector<std::pair<map::KeyframeId, Eigen::Vector3d>> keyframes = {
      {3, Eigen::Vector3d(0, 0, 0)}};
  KeyframeRuleParams params;  // threshold 0.4 at depth 4, parallax from 0.1
  params.max_view_turn_fraction = 0.25;
  const Eigen::Vector3d barely_moved(0.02, 0, 0);
  const Eigen::Vector3d turned(std::sin(0.3), 0, std::cos(0.3));
  ViewDirections view{turned, {Eigen::Vector3d::UnitZ()}, 1.0};
  for (const int now : {30, 190}) {
    const KeyframeDecision d =
        decideKeyframe(barely_moved, keyframes, 4.0, params, TrackedPoints{now, 200}, view);
    EXPECT_TRUE(d.drop) << now;
    EXPECT_TRUE(d.view_turned) << now;
    EXPECT_FALSE(d.view_leaving_map) << now;  // that rule still waits for the baseline
  }
  // A small turn (a still camera's shake, a weak map or not) is covered: wait.
  view.current = Eigen::Vector3d(std::sin(0.2), 0, std::cos(0.2));
  for (const int now : {30, 190}) {
    EXPECT_FALSE(
        decideKeyframe(barely_moved, keyframes, 4.0, params, TrackedPoints{now, 200}, view).drop);
  }
}

TEST(KeyframeRule, DrivingForwardWaitsForTheParallaxASidewaysStepWouldGive) {
  // Points on two walls 4 m to either side and 20-60 m ahead; the camera drives along z.
  std::vector<Eigen::Vector3d> walls;
  for (int i = 0; i <= 40; ++i) {
    walls.emplace_back(-4.0, 0.0, 20.0 + i);
    walls.emplace_back(4.0, 0.0, 20.0 + i);
  }
  const std::vector<std::pair<map::KeyframeId, Eigen::Vector3d>> keyframes = {
      {7, Eigen::Vector3d(0, 0, 0)}};
  KeyframeRuleParams params;  // 0.1 x depth; forward up to 0.25 x depth
  const double depth = 40.0;  // threshold 4 m
  TrackedPoints tracked{200, 200, 0, walls};
  // 5 m forward: past the distance, but the points' median parallax is ~0.6 deg, far below
  // atan(0.1) = 5.7 deg: wait.
  KeyframeDecision d = decideKeyframe(Eigen::Vector3d(0, 0, 5), keyframes, depth, params, tracked);
  EXPECT_FALSE(d.drop);
  EXPECT_NEAR(d.parallax, medianParallax(walls, Eigen::Vector3d::Zero(), {0, 0, 5}), 1e-12);
  EXPECT_LT(d.parallax, 0.02);
  // Without the points (or with the rule off) the distance alone decides.
  EXPECT_TRUE(decideKeyframe(Eigen::Vector3d(0, 0, 5), keyframes, depth, params).drop);
  params.max_distance_to_depth_ratio = 0.0;
  EXPECT_TRUE(decideKeyframe(Eigen::Vector3d(0, 0, 5), keyframes, depth, params, tracked).drop);
  params.max_distance_to_depth_ratio = 0.25;
  // Beyond 0.25 x depth (10 m) it drops whatever the parallax.
  EXPECT_TRUE(decideKeyframe(Eigen::Vector3d(0, 0, 10.5), keyframes, depth, params, tracked).drop);
  // The same 5 m sideways past points 40 m ahead: parallax ~7 deg, drop at the distance.
  std::vector<Eigen::Vector3d> ahead;
  for (int i = -20; i <= 20; ++i)
    ahead.emplace_back(i, 0.0, depth);
  tracked.points_world = ahead;
  d = decideKeyframe(Eigen::Vector3d(5, 0, 0), keyframes, depth, params, tracked);
  EXPECT_TRUE(d.drop);
  EXPECT_GT(d.parallax, std::atan(0.1));
  // While the forward step waits, the keyframe behind still covers the view (no view-turn drop).
  tracked.points_world = walls;
  const ViewDirections view{
      Eigen::Vector3d(std::sin(0.2), 0, std::cos(0.2)), {Eigen::Vector3d::UnitZ()}, 1.0};
  EXPECT_FALSE(
      decideKeyframe(Eigen::Vector3d(0, 0, 5), keyframes, depth, params, tracked, view).drop);
  params.max_distance_to_depth_ratio = 0.05;  // below the distance ratio
  EXPECT_THROW(params.validate(), std::invalid_argument);
}

TEST(KeyframeRule, MedianSceneDepthIgnoresPointsBehindTheCamera) {
  const geometry::SE3 T(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, 1));
  EXPECT_NEAR(medianSceneDepth(T, {{0, 0, 1}, {0, 0, 2}, {0, 0, 3}, {0, 0, -5}}), 3.0, 1e-12);
  EXPECT_THROW(medianSceneDepth(T, {{0, 0, -3}}), std::invalid_argument);
}

}  // namespace
}  // namespace scale_drift_slam::tracking
