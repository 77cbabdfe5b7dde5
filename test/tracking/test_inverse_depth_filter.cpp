// Inverse-depth filters against known depths: convergence as the parallax grows (near, far and
// infinitely far points), the parallax gate, rejection of outliers, and the promotion rule.

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "scale_drift_slam/tracking/inverse_depth_filter.h"

namespace scale_drift_slam::tracking {
namespace {

constexpr double kFocal = 500.0;

/// A camera at (x, 0, 0) looking along +z with a slight rotation (so the parallax test must
/// compensate it).
geometry::SE3 cameraAt(double x) {
  geometry::SE3::Tangent xi;
  xi << 0.01 * x, -0.02 * x, 0.005, 0.0, 0.0, 0.0;
  const geometry::SE3 R = geometry::SE3::exp(xi);
  return geometry::SE3(R.rotation(), -(R.rotation() * Eigen::Vector3d(x, 0.0, 0.0)));
}

Eigen::Vector2d observe(const geometry::SE3& T, const Eigen::Vector3d& p, std::mt19937& rng,
                        double sigma_px) {
  std::normal_distribution<double> n(0.0, sigma_px / kFocal);
  const Eigen::Vector3d y = T * p;
  return y.head<2>() / y.z() + Eigen::Vector2d(n(rng), n(rng));
}

/// Runs a filter on a point at `depth` in front of the first camera while the camera slides up to
/// `max_baseline` sideways; returns the filter. The start value of q is 1/5 (depth 5 m).
InverseDepthFilter runFilter(double depth, double max_baseline, unsigned seed,
                             std::vector<double>* relative_sigmas = nullptr) {
  std::mt19937 rng(seed);
  const geometry::SE3 T0 = cameraAt(0.0);
  const Eigen::Vector3d p = T0.inverse() * Eigen::Vector3d(0.3 * depth, -0.1 * depth, depth);
  InverseDepthFilter filter(7, T0, observe(T0, p, rng, 1.0), 0.2, kFocal,
                            InverseDepthFilterParams());
  for (int i = 1; i <= 60; ++i) {
    const geometry::SE3 T = cameraAt(max_baseline * i / 60.0);
    if (filter.update(T, observe(T, p, rng, 1.0)) == InverseDepthFilter::Update::kUpdated &&
        relative_sigmas != nullptr) {
      relative_sigmas->push_back(filter.relativeDepthSigma());
    }
  }
  return filter;
}

TEST(InverseDepthFilter, ConvergesToTheTrueDepthAsParallaxGrows) {
  // (depth, baseline): near, mid and far points (far: 200 m, seen over a 20 m baseline).
  const std::vector<std::pair<double, double>> cases = {{2.0, 0.5}, {8.0, 2.0}, {200.0, 20.0}};
  for (const auto& [depth, baseline] : cases) {
    for (unsigned seed : {1u, 2u, 3u}) {
      std::vector<double> sigmas;
      const InverseDepthFilter filter = runFilter(depth, baseline, seed, &sigmas);
      ASSERT_GT(filter.numUpdates(), 20) << depth;
      const double estimated_depth = filter.pointInOrigin().z();
      const double relative_error = std::abs(estimated_depth - depth) / depth;
      // Within 3 sigma of the filter's own uncertainty, and that uncertainty is small.
      EXPECT_LT(relative_error, 3.0 * filter.relativeDepthSigma() + 1e-3) << depth << " " << seed;
      EXPECT_LT(filter.relativeDepthSigma(), 0.02) << depth;
      EXPECT_TRUE(filter.isCertain());
      // The uncertainty shrinks as the parallax grows.
      EXPECT_LT(sigmas.back(), 0.5 * sigmas.front()) << depth;
      // (u, v) stay at the first observation up to the pixel noise.
      EXPECT_LT((filter.state().head<2>() - Eigen::Vector2d(0.3, -0.1)).norm() * kFocal, 3.0);
    }
  }
}

TEST(InverseDepthFilter, APointAtInfinityStaysUncertain) {
  std::mt19937 rng(4);
  const geometry::SE3 T0 = cameraAt(0.0);
  const Eigen::Vector3d direction = T0.inverse().rotation() * Eigen::Vector3d(0.1, 0.1, 1.0);
  InverseDepthFilterParams params;
  params.min_parallax_deg = 0.0;  // update on every frame
  InverseDepthFilter filter(1, T0, Eigen::Vector2d(0.1, 0.1), 0.5, kFocal, params);
  for (int i = 1; i <= 30; ++i) {
    const geometry::SE3 T = cameraAt(0.1 * i);
    // The image of a point at infinity only depends on the rotation.
    const Eigen::Vector3d y = T.rotation() * direction;
    filter.update(T, y.head<2>() / y.z());
  }
  EXPECT_LT(filter.state().z(), 0.02);  // q -> 0: depth > 50 m
  EXPECT_FALSE(filter.isCertain());
}

TEST(InverseDepthFilter, TheParallaxGateAndTheOutlierGateLeaveTheStateUnchanged) {
  std::mt19937 rng(5);
  const geometry::SE3 T0 = cameraAt(0.0);
  const Eigen::Vector3d p = T0.inverse() * Eigen::Vector3d(0.0, 0.0, 10.0);
  InverseDepthFilter filter(1, T0, observe(T0, p, rng, 0.0), 0.2, kFocal,
                            InverseDepthFilterParams());
  // 5 cm at 10 m: 0.29 degrees of parallax, below the 1 degree gate.
  const geometry::SE3 T_small = cameraAt(0.05);
  EXPECT_LT(filter.parallax(T_small, observe(T_small, p, rng, 0.0)), 0.3 * M_PI / 180.0);
  EXPECT_EQ(filter.update(T_small, observe(T_small, p, rng, 0.0)),
            InverseDepthFilter::Update::kLowParallax);
  EXPECT_EQ(filter.numUpdates(), 0);
  // Pure rotation gives zero parallax whatever the depth.
  geometry::SE3::Tangent xi;
  xi << 0.0, 0.2, 0.0, 0.0, 0.0, 0.0;
  const geometry::SE3 T_rot = geometry::SE3::exp(xi) * T0;
  EXPECT_NEAR(filter.parallax(T_rot, observe(T_rot, p, rng, 0.0)), 0.0, 1e-9);

  const geometry::SE3 T1 = cameraAt(1.0);
  ASSERT_EQ(filter.update(T1, observe(T1, p, rng, 0.5)), InverseDepthFilter::Update::kUpdated);
  const Eigen::Vector3d state = filter.state();
  // An observation 30 px off the epipolar line cannot be explained by any depth.
  const geometry::SE3 T2 = cameraAt(1.5);
  const Eigen::Vector2d wrong = observe(T2, p, rng, 0.0) + Eigen::Vector2d(0.0, 30.0 / kFocal);
  EXPECT_EQ(filter.update(T2, wrong), InverseDepthFilter::Update::kRejected);
  EXPECT_EQ(filter.state(), state);
  EXPECT_EQ(filter.numUpdates(), 1);
}

// A feature that keeps its pixel while the camera slides and turns: texture fixed to the sensor
// (kSensorFixedPx). The views are built so that a world point at 0.4 m does the same (the slide
// undoes the turn's image motion), so every other test the filter makes passes; it used to be
// updated towards that depth and promoted. A point 2 px from there is updated as before.
TEST(InverseDepthFilter, AFeatureThatKeepsItsPixelThroughParallaxIsFixedToTheSensor) {
  const geometry::SE3 T0;  // the origin camera at the world's origin
  const Eigen::Vector3d p(0.1, 0.02, 0.4);
  const Eigen::Matrix3d R =
      geometry::SE3::exp((geometry::SE3::Tangent() << 0, 0.05, 0, 0, 0, 0).finished())
          .rotationMatrix();                    // 2.9 degrees about the vertical
  const geometry::SE3 T1(R, 1.05 * p - R * p);  // p at the same pixel, 5 % further away
  const Eigen::Vector2d xy = p.head<2>() / p.z();
  const Eigen::Vector3d in_1 = T1 * p;
  ASSERT_LT(kFocal * (in_1.head<2>() / in_1.z() - xy).norm(), 1e-9);
  InverseDepthFilter fixed(1, T0, xy, 2.0, kFocal, InverseDepthFilterParams());
  ASSERT_GT(fixed.parallax(T1, xy), 2.0 * M_PI / 180.0);
  EXPECT_EQ(fixed.update(T1, xy), InverseDepthFilter::Update::kRejected);
  EXPECT_EQ(fixed.numUpdates(), 0);
  // The same views, the point 2 px along the epipolar line: the world, updated.
  InverseDepthFilter world(1, T0, xy, 2.0, kFocal, InverseDepthFilterParams());
  const Eigen::Vector2d moved = xy + Eigen::Vector2d(2.0 / kFocal, 0.0);
  EXPECT_EQ(world.update(T1, moved), InverseDepthFilter::Update::kUpdated);
}

TEST(FeaturePromotion, AcceptsAConsistentPointAndRejectsALargeError) {
  const InverseDepthFilter filter = runFilter(6.0, 1.5, 9);
  const geometry::SE3 T0 = cameraAt(0.0);
  const Eigen::Vector3d p = T0.inverse() * Eigen::Vector3d(1.8, -0.6, 6.0);
  std::mt19937 rng(3);
  std::vector<PromotionView> views;
  for (int k = 0; k < 3; ++k) {
    const geometry::SE3 T = cameraAt(0.6 * k);
    views.push_back({static_cast<map::KeyframeId>(k), T, observe(T, p, rng, 0.5)});
  }
  const PromotionResult good = promoteFeature(filter, views, kFocal);
  EXPECT_TRUE(good.accepted) << good.reason;
  EXPECT_LT((good.p_world - p).norm(), 0.1);
  ASSERT_EQ(good.errors_px.size(), 3u);
  for (double e : good.errors_px)
    EXPECT_LT(e, 1.5);

  views[1].xy += Eigen::Vector2d(0.0, 15.0 / kFocal);
  const PromotionResult bad = promoteFeature(filter, views, kFocal);
  EXPECT_FALSE(bad.accepted);
  EXPECT_NE(bad.reason.find("reprojection error"), std::string::npos);

  EXPECT_FALSE(promoteFeature(filter, {views[0]}, kFocal).accepted);
}

TEST(FeaturePromotion, RejectsAPointThatRunsFarFromTheFiltersDepth) {
  // The filter is certain of a depth of 6; the keyframes' views agree with a point 1000 times as
  // far on the same ray (so far that their baselines give it no parallax): the adjustment runs
  // out along the ray with small reprojection errors, and the promotion must refuse it.
  const InverseDepthFilter filter = runFilter(6.0, 1.5, 9);
  ASSERT_TRUE(filter.isCertain());
  const geometry::SE3 T0 = cameraAt(0.0);
  const Eigen::Vector3d far = T0.inverse() * (Eigen::Vector3d(1.8, -0.6, 6.0) * 1000.0);
  std::vector<PromotionView> views;
  for (int k = 0; k < 3; ++k) {
    const geometry::SE3 T = cameraAt(0.6 * k);
    const Eigen::Vector3d y = T * far;
    views.push_back({static_cast<map::KeyframeId>(k), T, y.head<2>() / y.z()});
  }
  const PromotionResult result = promoteFeature(filter, views, kFocal);
  EXPECT_FALSE(result.accepted) << "promoted at " << result.p_world.transpose();
  EXPECT_NE(result.reason.find("far from the filter"), std::string::npos) << result.reason;
}

TEST(InverseDepthFilter, RejectsBadInput) {
  InverseDepthFilterParams params;
  params.pixel_sigma_px = 0.0;
  EXPECT_THROW(params.validate(), std::invalid_argument);
  EXPECT_THROW(InverseDepthFilter(1, geometry::SE3(), Eigen::Vector2d(0, 0), -1.0, kFocal,
                                  InverseDepthFilterParams()),
               std::invalid_argument);
  EXPECT_THROW(InverseDepthFilter(1, geometry::SE3(), Eigen::Vector2d(NAN, 0), 1.0, kFocal,
                                  InverseDepthFilterParams()),
               std::invalid_argument);
}

}  // namespace
}  // namespace scale_drift_slam::tracking
