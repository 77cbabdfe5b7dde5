// The 7-DoF loop constraint from 2D-3D (P3P RANSAC + refinement) and 3D-3D (median scale ratio)
// correspondences, against a known similarity, with noise and outliers.

#include <random>

#include <gtest/gtest.h>

#include "scale_drift_slam/loop/loop_constraint.h"

namespace scale_drift_slam::loop {
namespace {

constexpr double kFocal = 300.0;

struct Truth {
  geometry::SE3 T_current_loop;  // loop scale
  double scale;
};

LoopConstraintInput makeInput(const Truth& truth, int n, double outlier_fraction, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0), unit(0.0, 1.0);
  std::normal_distribution<double> pixel(0.0, 1.0 / kFocal), depth_noise(0.0, 0.01);
  LoopConstraintInput input;
  input.current_id = 50;
  input.loop_id = 3;
  input.focal_length_px = kFocal;
  const geometry::SE3 T_loop_current = truth.T_current_loop.inverse();
  for (int i = 0; i < n; ++i) {
    // A point seen by the current camera, 2..6 loop-units ahead.
    const double z = 2.0 + 4.0 * unit(rng);
    const Eigen::Vector3d in_current_loop_scale(0.5 * u(rng) * z, 0.4 * u(rng) * z, z);
    const Eigen::Vector3d p_loop = T_loop_current * in_current_loop_scale;
    Match2D3D m{in_current_loop_scale.head<2>() / z + Eigen::Vector2d(pixel(rng), pixel(rng)),
                p_loop};
    if (unit(rng) < outlier_fraction) m.xy_current += 0.3 * Eigen::Vector2d(u(rng), u(rng));
    input.matches.push_back(m);
    // The same point in the current map: scaled, with 1% depth noise, some gross errors.
    Eigen::Vector3d p_current = truth.scale * in_current_loop_scale * (1.0 + depth_noise(rng));
    if (unit(rng) < outlier_fraction) p_current *= 3.0 * unit(rng) + 0.2;
    input.point_pairs.push_back(
        {p_current, p_loop + 0.01 * Eigen::Vector3d(u(rng), u(rng), u(rng))});
  }
  return input;
}

Truth makeTruth() {
  geometry::SE3::Tangent xi;
  xi << 0.2, -0.5, 0.1, 0.8, -0.3, 0.4;
  return {geometry::SE3::exp(xi), 1.37};
}

TEST(LoopConstraint, RecoversAKnownPoseAndScaleDespiteOutliers) {
  const Truth truth = makeTruth();
  for (unsigned seed : {1u, 2u, 3u}) {
    const LoopConstraintInput input = makeInput(truth, 120, 0.3, seed);
    const LoopConstraintResult result = estimateLoopConstraint(input, LoopConstraintParams());
    ASSERT_TRUE(result.success) << result.reason;
    const LoopConstraint& c = result.constraint;
    const geometry::SE3::Tangent error = (c.T_current_loop * truth.T_current_loop.inverse()).log();
    EXPECT_LT(error.head<3>().norm(), 3e-3) << seed;
    EXPECT_LT(error.tail<3>().norm(), 2e-2) << seed;  // 1 px at f = 300, points 2..6 ahead
    EXPECT_NEAR(c.scale, truth.scale, 0.01 * truth.scale) << seed;
    EXPECT_GT(c.num_inliers, 70);
    EXPECT_LT(c.num_inliers, 95);
    EXPECT_LT(c.rmse_px, 1.6);
    // The similarity maps loop coordinates into current-map coordinates.
    const Eigen::Vector3d p_loop(0.3, -0.2, 4.0);
    const Eigen::Vector3d expected = truth.scale * (truth.T_current_loop * p_loop);
    EXPECT_LT((c.S_current_loop * p_loop - expected).norm(), 0.05);
    EXPECT_NEAR(c.S_current_loop.scale(), c.scale, 1e-12);
    EXPECT_EQ(c.current_id, 50u);
    EXPECT_EQ(c.loop_id, 3u);
  }
}

TEST(LoopConstraint, ReportsTooLittleSupport) {
  const Truth truth = makeTruth();
  LoopConstraintInput input = makeInput(truth, 8, 0.0, 4);
  EXPECT_FALSE(estimateLoopConstraint(input, LoopConstraintParams()).success);
  input = makeInput(truth, 100, 0.95, 5);  // almost all matches wrong
  const LoopConstraintResult result = estimateLoopConstraint(input, LoopConstraintParams());
  EXPECT_FALSE(result.success);
  EXPECT_FALSE(result.reason.empty());
  input = makeInput(truth, 50, 0.0, 6);
  input.point_pairs.resize(2);
  EXPECT_FALSE(estimateLoopConstraint(input, LoopConstraintParams()).success);
  input.focal_length_px = 0.0;
  EXPECT_THROW(estimateLoopConstraint(input, LoopConstraintParams()), std::invalid_argument);
}

}  // namespace
}  // namespace scale_drift_slam::loop
