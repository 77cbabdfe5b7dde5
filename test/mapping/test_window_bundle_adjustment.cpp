// Sliding-window BA against a known scene: noisy observations, perturbed start, fixed gauge.

#include <algorithm>
#include <random>

#include <gtest/gtest.h>

#include "scale_drift_slam/map/map.h"
#include "scale_drift_slam/mapping/window_bundle_adjustment.h"
#include "scene.h"

namespace scale_drift_slam::mapping {
namespace {

constexpr double kFocal = 500.0;

/// A map of `num_keyframes` keyframes over the test scene, with pixel noise on the observations,
/// poses (except the first two) and points perturbed. Also returns the truth.
map::Map makeNoisyMap(int num_keyframes, double noise_px, double outlier_fraction,
                      testing::Scene* truth) {
  *truth = testing::makeScene(num_keyframes, 400, 0.25, 7);
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, noise_px / kFocal);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  map::Map map;
  for (std::size_t j = 0; j < truth->points.size(); ++j) {
    map::MapPoint p;
    p.id = static_cast<map::PointId>(j);
    p.p_world = truth->points[j] + 0.1 * Eigen::Vector3d(noise(rng), noise(rng), noise(rng)) *
                                       kFocal / std::max(noise_px, 1e-9);
    map.addPoint(p);
  }
  for (int i = 0; i < num_keyframes; ++i) {
    map::Keyframe kf;
    kf.id = static_cast<map::KeyframeId>(100 + i);
    const geometry::SE3& T = truth->T_cam_world[i];
    kf.T_kf_world = i < 2 ? T : testing::perturb(T, 0.01, 0.05, rng);
    map.addKeyframe(kf);
    for (std::size_t j = 0; j < truth->points.size(); ++j) {
      if (!testing::visible(T, truth->points[j], 0.6)) continue;
      Eigen::Vector2d xy = testing::project(T, truth->points[j]);
      xy += Eigen::Vector2d(noise(rng), noise(rng));
      if (unit(rng) < outlier_fraction) xy += Eigen::Vector2d(40.0, -30.0) / kFocal;
      map.addObservation(kf.id, static_cast<map::PointId>(j), xy);
    }
  }
  return map;
}

TEST(WindowBundleAdjustment, ReducesErrorAndKeepsTheFixedKeyframesFixed) {
  testing::Scene truth;
  map::Map map = makeNoisyMap(10, 1.0, 0.02, &truth);
  WindowBundleAdjustmentParams params;
  const WindowBundleInput input = makeWindowInput(map, params, kFocal);
  ASSERT_EQ(input.keyframes.size(), 10u);
  EXPECT_TRUE(input.keyframes[0].fixed && input.keyframes[1].fixed && !input.keyframes[2].fixed);

  const WindowBundleResult result = solveWindowBundleAdjustment(input, params);
  const features::BundleStatistics& stats = result.statistics;
  EXPECT_LT(stats.final_cost, 0.2 * stats.initial_cost);
  EXPECT_GT(stats.iterations, 0);
  // The residual of the inliers falls to the noise level (1 px, 2 coordinates: ~1.41 RMS).
  EXPECT_LT(stats.final_rmse_px, 1.6);
  EXPECT_GT(stats.initial_rmse_px, 5.0);
  // Outliers (2%, 50 px) are flagged; nearly all others are inliers.
  EXPECT_GT(stats.num_inliers, 0.93 * stats.num_observations);
  EXPECT_LT(stats.num_inliers, 0.995 * stats.num_observations);

  // Fixed keyframes are bit-identical; free ones come back to the truth (the gauge is the truth's).
  for (std::size_t k = 0; k < result.keyframes.size(); ++k) {
    const geometry::SE3& before = input.keyframes[k].T_kf_world;
    const geometry::SE3& after = result.keyframes[k].T_kf_world;
    if (k < 2) {
      EXPECT_EQ((before.matrix() - after.matrix()).norm(), 0.0);
      continue;
    }
    // The gauge comes from two keyframes 0.25 m apart at 5 m depth: the scale is known to
    // ~0.3% (1 px noise), i.e. ~1 cm at the far end of the 2.25 m window.
    const double error_before = testing::positionError(before, truth.T_cam_world[k]);
    const double error_after = testing::positionError(after, truth.T_cam_world[k]);
    EXPECT_LT(error_after, 0.3 * error_before) << k;
    EXPECT_LT(error_after, 0.025) << k;
  }
  // Free points (seen twice or more) move from ~0.17 m to a few cm, the error the gauge leaves
  // (~0.6% of scale at 5 m depth). The median: a few points seen twice from close keyframes keep
  // a poorly determined depth.
  std::vector<double> before, after;
  for (std::size_t j = 0; j < result.points.size(); ++j) {
    if (input.points[j].fixed) continue;
    before.push_back((input.points[j].p_world - truth.points[input.points[j].id]).norm());
    after.push_back((result.points[j].p_world - truth.points[result.points[j].id]).norm());
  }
  ASSERT_GT(after.size(), 300u);
  std::nth_element(before.begin(), before.begin() + before.size() / 2, before.end());
  std::nth_element(after.begin(), after.begin() + after.size() / 2, after.end());
  EXPECT_LT(after[after.size() / 2], 0.3 * before[before.size() / 2]);
  EXPECT_LT(after[after.size() / 2], 0.06);

  // Applying writes the free poses and points and bumps the version.
  const std::uint64_t version = map.version();
  EXPECT_GT(applyWindowResult(result, map), 8u);
  EXPECT_GT(map.version(), version);
  EXPECT_EQ(
      (map.keyframe(109).T_kf_world.matrix() - result.keyframes[9].T_kf_world.matrix()).norm(),
      0.0);
}

TEST(WindowBundleAdjustment, WindowTakesTheNewestKeyframesAndFixesSinglyObservedPoints) {
  testing::Scene truth;
  map::Map map = makeNoisyMap(14, 0.5, 0.0, &truth);
  // A point seen only by the newest keyframe.
  map.addPoint({9999, Eigen::Vector3d(1, 0, 5), 113, {}});
  map.addObservation(113, 9999, Eigen::Vector2d(0.1, 0.0));
  WindowBundleAdjustmentParams params;
  const WindowBundleInput input = makeWindowInput(map, params, kFocal);
  ASSERT_EQ(input.keyframes.size(), 10u);
  EXPECT_EQ(input.keyframes.front().id, 104u);
  EXPECT_EQ(input.keyframes.back().id, 113u);
  bool found = false;
  for (const BundlePoint& p : input.points) {
    if (p.id != 9999) continue;
    found = true;
    EXPECT_TRUE(p.fixed);
  }
  EXPECT_TRUE(found);
  const WindowBundleResult result = solveWindowBundleAdjustment(input, params);
  for (std::size_t j = 0; j < input.points.size(); ++j) {
    if (input.points[j].fixed) {
      EXPECT_EQ(result.points[j].p_world, input.points[j].p_world);
    }
  }
  EXPECT_LT(result.statistics.final_rmse_px, 1.2);  // 0.5 px noise plus the fixed points' error
}

TEST(WindowBundleAdjustment, LeavesOutPointsThatOnlyTheFixedKeyframesSee) {
  testing::Scene truth;
  map::Map map = makeNoisyMap(14, 0.5, 0.0, &truth);
  // The window is keyframes 104..113 with 104 and 105 fixed. Point 9997 is seen by the fixed pair
  // only (it constrains no free pose: left out, its position untouched); 9996 by a fixed and a
  // free keyframe (in, free).
  const Eigen::Vector3d p(0.5, 0.2, 5.0);
  map.addPoint({9997, p, 104, {}});
  map.addPoint({9996, p + Eigen::Vector3d(0.1, 0.0, 0.0), 104, {}});
  for (map::KeyframeId id : {104u, 105u}) {
    const Eigen::Vector3d y = map.keyframe(id).T_kf_world * p;
    map.addObservation(id, 9997, y.head<2>() / y.z());
  }
  for (map::KeyframeId id : {104u, 110u}) {
    const Eigen::Vector3d y = map.keyframe(id).T_kf_world * (p + Eigen::Vector3d(0.1, 0.0, 0.0));
    map.addObservation(id, 9996, y.head<2>() / y.z());
  }
  const WindowBundleInput input = makeWindowInput(map, WindowBundleAdjustmentParams(), kFocal);
  bool found_9996 = false;
  for (const BundlePoint& point : input.points) {
    EXPECT_NE(point.id, 9997u);
    if (point.id == 9996u) found_9996 = !point.fixed;
  }
  EXPECT_TRUE(found_9996);
  // Every point of the window is seen by at least one free keyframe.
  std::vector<int> free_views(input.points.size(), 0);
  for (const BundleObservation& o : input.observations)
    free_views[o.point_index] += input.keyframes[o.keyframe_index].fixed ? 0 : 1;
  EXPECT_EQ(std::count(free_views.begin(), free_views.end(), 0), 0);
  const WindowBundleResult result =
      solveWindowBundleAdjustment(input, WindowBundleAdjustmentParams());
  applyWindowResult(result, map);
  EXPECT_EQ(map.point(9997).p_world, p);
}

TEST(WindowBundleAdjustment, RejectsBadInput) {
  WindowBundleAdjustmentParams params;
  params.num_fixed_keyframes = 1;
  EXPECT_THROW(params.validate(), std::invalid_argument);
  params = WindowBundleAdjustmentParams();
  params.huber_width_px = 0.0;
  EXPECT_THROW(params.validate(), std::invalid_argument);

  map::Map tiny;
  tiny.addKeyframe({1, 0.0, geometry::SE3(), {}});
  EXPECT_THROW(makeWindowInput(tiny, WindowBundleAdjustmentParams(), kFocal),
               std::invalid_argument);

  WindowBundleInput input;
  input.focal_length_px = kFocal;
  input.keyframes.push_back({1, geometry::SE3(), true});
  input.observations.push_back({0, 3, Eigen::Vector2d::Zero()});
  EXPECT_THROW(solveWindowBundleAdjustment(input, WindowBundleAdjustmentParams()),
               std::invalid_argument);
  input.observations.clear();
  input.focal_length_px = -1.0;
  EXPECT_THROW(solveWindowBundleAdjustment(input, WindowBundleAdjustmentParams()),
               std::invalid_argument);
}

}  // namespace
}  // namespace scale_drift_slam::mapping
