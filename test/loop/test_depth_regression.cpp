// k-nearest-neighbour depth regression over a keyframe's projected map points: it reproduces a
// surface between the points, refuses at a depth discontinuity and far from every point.

#include <random>

#include <gtest/gtest.h>

#include "scale_drift_slam/loop/depth_regression.h"

namespace scale_drift_slam::loop {
namespace {

constexpr double kFocal = 400.0;

/// Points on the plane z = a + b x (camera frame), at random normalised coordinates.
void samplePlane(double a, double b, int n, std::mt19937& rng, double x_min, double x_max,
                 std::vector<Eigen::Vector2d>* xy, std::vector<double>* depths) {
  std::uniform_real_distribution<double> ux(x_min, x_max), uy(-0.5, 0.5);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2d p(ux(rng), uy(rng));
    // The ray (x, y, 1) z meets z = a + b x z: z = a / (1 - b x).
    xy->push_back(p);
    depths->push_back(a / (1.0 - b * p.x()));
  }
}

TEST(DepthRegression, InterpolatesASlantedSurface) {
  std::mt19937 rng(3);
  std::vector<Eigen::Vector2d> xy;
  std::vector<double> depths;
  samplePlane(4.0, 0.4, 300, rng, -0.7, 0.7, &xy, &depths);
  const DepthRegressor regressor(xy, depths, kFocal, DepthRegressionParams{});
  std::uniform_real_distribution<double> ux(-0.6, 0.6), uy(-0.45, 0.45);
  int answered = 0;
  double worst = 0.0;
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector2d q(ux(rng), uy(rng));
    const std::optional<double> depth = regressor.depthAt(q);
    if (!depth) continue;
    ++answered;
    const double truth = 4.0 / (1.0 - 0.4 * q.x());
    worst = std::max(worst, std::abs(*depth - truth) / truth);
  }
  EXPECT_GT(answered, 180);  // dense enough: nearly everywhere
  EXPECT_LT(worst, 0.02);    // within 2 % of the true depth
  const std::optional<Eigen::Vector3d> p = regressor.pointAt(Eigen::Vector2d(0.1, 0.2));
  ASSERT_TRUE(p.has_value());
  EXPECT_NEAR(p->x() / p->z(), 0.1, 1e-12);
  EXPECT_NEAR(p->y() / p->z(), 0.2, 1e-12);
}

TEST(DepthRegression, RefusesAtADepthEdgeAndFarFromThePoints) {
  std::mt19937 rng(4);
  std::vector<Eigen::Vector2d> xy;
  std::vector<double> depths;
  samplePlane(2.0, 0.0, 200, rng, -0.6, 0.0, &xy, &depths);  // near wall on the left
  samplePlane(6.0, 0.0, 200, rng, 0.0, 0.6, &xy, &depths);   // far wall on the right
  const DepthRegressor regressor(xy, depths, kFocal, DepthRegressionParams{});
  EXPECT_FALSE(regressor.depthAt(Eigen::Vector2d(0.0, 0.0)).has_value());  // on the edge
  ASSERT_TRUE(regressor.depthAt(Eigen::Vector2d(-0.3, 0.0)).has_value());
  EXPECT_NEAR(*regressor.depthAt(Eigen::Vector2d(-0.3, 0.0)), 2.0, 1e-9);
  EXPECT_NEAR(*regressor.depthAt(Eigen::Vector2d(0.3, 0.0)), 6.0, 1e-9);
  EXPECT_FALSE(regressor.depthAt(Eigen::Vector2d(0.0, 2.0)).has_value());  // nothing near
}

TEST(DepthRegression, RejectsBadInput) {
  EXPECT_THROW(DepthRegressor({Eigen::Vector2d::Zero()}, {}, kFocal, DepthRegressionParams{}),
               std::invalid_argument);
  EXPECT_THROW(DepthRegressor({}, {}, 0.0, DepthRegressionParams{}), std::invalid_argument);
  DepthRegressionParams bad;
  bad.min_neighbours = bad.k + 1;  // more than k
  EXPECT_THROW(DepthRegressor({}, {}, kFocal, bad), std::invalid_argument);
  // Points behind the camera or not finite are skipped, not used.
  const DepthRegressor regressor({Eigen::Vector2d::Zero(), Eigen::Vector2d(0.01, 0)},
                                 {-1.0, std::nan("")}, kFocal, DepthRegressionParams{});
  EXPECT_EQ(regressor.size(), 0u);
}

}  // namespace
}  // namespace scale_drift_slam::loop
