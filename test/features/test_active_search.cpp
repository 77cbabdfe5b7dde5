// Active search on rendered views of a textured wall with known geometry: points cut from a
// reference view are found again in a rotated, closer view (the perspective warp makes this
// possible) at their true pixels to a fraction of a pixel, from a perturbed prior pose; a point
// with a wrong prediction far outside its region is not matched; the warp equals finite
// differences of the projection.

#include <gtest/gtest.h>

#include "../tracking/synthetic_images.h"
#include "scale_drift_slam/features/active_search.h"
#include "scale_drift_slam/geometry/so3.h"

namespace scale_drift_slam::features {
namespace {

std::shared_ptr<const geometry::CameraModel> camera() {
  return test::pinholeCamera(500.0);
}

struct WallScene {
  test::TexturedPlane wall;
  geometry::SE3 T_ref_world, T_cur_world;
  ImagePyramid ref, cur;
  std::vector<Eigen::Vector3d> points;
  std::vector<PointAppearance> appearances;
};

WallScene makeScene(const geometry::SE3& T_cur_world) {
  WallScene s;
  s.wall.texture = test::texturedImage(1600, 1200, 31);
  s.wall.origin = Eigen::Vector3d(0, 0, 3.0);
  s.wall.axis_u = Eigen::Vector3d(1, 0, 0);
  s.wall.axis_v = Eigen::Vector3d(0, 1, 0);
  s.wall.metres_per_pixel = 0.004;
  s.T_cur_world = T_cur_world;
  const auto cam = camera();
  s.ref = buildPyramid(test::renderPlanes({s.wall}, cam->K(), s.T_ref_world, 640, 480), 4);
  s.cur = buildPyramid(test::renderPlanes({s.wall}, cam->K(), s.T_cur_world, 640, 480), 4);
  for (const cv::KeyPoint& k : detectSpreadCorners(s.ref.base(), 300, {})) {
    const Eigen::Vector2d px(k.pt.x, k.pt.y);
    const Eigen::Vector3d ray = cam->unproject(px);
    s.points.push_back(ray * (3.0 / ray.z()));  // on the wall z = 3 (reference = world)
    s.appearances.emplace_back();
    s.appearances.back().cut(s.ref, px);
  }
  return s;
}

/// 20 degrees about the optical axis, 0.6 m closer (scale change 1.25), a little sideways.
WallScene rotatedCloserView() {
  const geometry::SE3 T_world_cur(geometry::expSO3(Eigen::Vector3d(0.02, -0.03, 0.35)),
                                  Eigen::Vector3d(0.1, 0.05, 0.6));
  return makeScene(T_world_cur.inverse());
}

/// The current pose off by ~0.01 rad and 2 cm: several pixels.
geometry::SE3 perturbedPrior(const WallScene& s) {
  return geometry::SE3::exp(
             (Eigen::Matrix<double, 6, 1>() << 0.004, -0.006, 0.003, 0.01, -0.01, 0.005)
                 .finished()) *
         s.T_cur_world;
}

struct Outcome {
  int visible = 0, found = 0;
  double median_error_px = 1e9;
};

Outcome search(const WallScene& s, const geometry::SE3& prior, double sigma,
               const ActiveSearchParams& params = {}) {
  const auto cam = camera();
  std::vector<SearchPoint> points;
  for (std::size_t i = 0; i < s.points.size(); ++i) {
    points.push_back({s.points[i], s.T_ref_world, &s.appearances[i]});
  }
  const Eigen::Matrix<double, 6, 6> Sigma = Eigen::Matrix<double, 6, 6>::Identity() * sigma * sigma;
  const auto matches =
      activeSearch(points, prior, Sigma, *cam, s.cur, detectSearchCorners(s.cur, params), params);
  Outcome o;
  std::vector<double> errors;
  for (std::size_t i = 0; i < matches.size(); ++i) {
    o.visible += matches[i].visible;
    if (!matches[i].found) continue;
    ++o.found;
    const Eigen::Vector2d truth = *cam->project(s.T_cur_world * s.points[i]);
    errors.push_back((matches[i].px - truth).norm());
    EXPECT_LT((matches[i].xy - cam->undistortToNormalized(matches[i].px)).norm(), 1e-9);
  }
  if (!errors.empty()) {
    std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
    o.median_error_px = errors[errors.size() / 2];
  }
  return o;
}

TEST(PointAppearance, HoldsThePixelsAroundThePointAtBothLevels) {
  const WallScene s = makeScene(geometry::SE3());
  const Eigen::Vector2d px(200.0, 150.0);
  PointAppearance appearance;
  ASSERT_TRUE(appearance.cut(s.ref, px));
  const int r = PointAppearance::kPatchRadius;
  const cv::Mat level0 = s.ref.levels[0](cv::Rect(200 - r, 150 - r, 2 * r + 1, 2 * r + 1));
  const cv::Mat level1 = s.ref.levels[1](cv::Rect(100 - r, 75 - r, 2 * r + 1, 2 * r + 1));
  EXPECT_EQ(cv::norm(appearance.patch(0), level0, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(appearance.patch(1), level1, cv::NORM_INF), 0.0);
  // A copy owns its pixels: cutting the original elsewhere leaves the copy as it was.
  const PointAppearance copy = appearance;
  ASSERT_TRUE(appearance.cut(s.ref, Eigen::Vector2d(400.0, 300.0)));
  EXPECT_EQ(cv::norm(copy.patch(0), level0, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(appearance.patch(0), level0, cv::NORM_INF), 0.0);
  // Too close to the border: nothing cut, and empty.
  EXPECT_FALSE(appearance.cut(s.ref, Eigen::Vector2d(3.0, 3.0)));
  EXPECT_TRUE(appearance.empty());
  EXPECT_TRUE(appearance.patch(0).empty());
  // Patches set from outside must be grey and of the patch size.
  PointAppearance loaded;
  loaded.setPatches(level0.clone(), level1.clone());
  EXPECT_EQ(cv::norm(loaded.patch(1), level1, cv::NORM_INF), 0.0);
  EXPECT_THROW(loaded.setPatches(level0, cv::Mat(5, 5, CV_8UC1)), std::invalid_argument);
  EXPECT_THROW(loaded.setPatches(cv::Mat(21, 21, CV_8UC3), level1), std::invalid_argument);
  loaded.setPatches(cv::Mat(), cv::Mat());
  EXPECT_TRUE(loaded.empty());
}

TEST(ActiveSearch, FindsPointsInARotatedCloserView) {
  const WallScene s = rotatedCloserView();
  const geometry::SE3 prior = perturbedPrior(s);
  const Outcome o = search(s, prior, 0.01);
  ASSERT_GT(o.visible, 150);
  EXPECT_GT(o.found, 0.9 * o.visible);
  EXPECT_LT(o.median_error_px, 0.3);
}

TEST(PointAppearance, CompressedPatchesKeepHalfThePixelsWithin1Of30OfTheirRange) {
  const WallScene s = makeScene(geometry::SE3());
  PointAppearance appearance;
  ASSERT_TRUE(appearance.cut(s.ref, Eigen::Vector2d(200.0, 150.0)));
  const cv::Mat original[2] = {appearance.patch(0).clone(), appearance.patch(1).clone()};
  const std::size_t full_bytes = appearance.pixelBytes();
  appearance.compress();
  EXPECT_TRUE(appearance.compressed());
  EXPECT_LE(appearance.pixelBytes(), full_bytes / 2 + 1);
  appearance.compress();  // idempotent
  for (int level = 0; level < 2; ++level) {
    double lo = 0.0, hi = 0.0;
    cv::minMaxLoc(original[level], &lo, &hi);
    ASSERT_GT(hi - lo, 20.0);  // a textured patch: the bound below means something
    const cv::Mat decoded = appearance.patch(level);
    ASSERT_EQ(decoded.size(), original[level].size());
    EXPECT_LE(cv::norm(decoded, original[level], cv::NORM_INF), (hi - lo) / 30.0 + 0.5);
    EXPECT_GT(cv::norm(decoded, original[level], cv::NORM_INF), 0.0);  // lossy, not a copy
  }
  // Expanded: 8 bits again, the same (quantised) pixels as the compressed form gave.
  const cv::Mat decoded0 = appearance.patch(0).clone();
  appearance.expand();
  EXPECT_FALSE(appearance.compressed());
  EXPECT_EQ(appearance.pixelBytes(), full_bytes);
  EXPECT_EQ(cv::norm(appearance.patch(0), decoded0, cv::NORM_INF), 0.0);
  // A flat patch compresses to itself.
  PointAppearance flat;
  flat.setPatches(cv::Mat(21, 21, CV_8UC1, cv::Scalar(77)),
                  cv::Mat(21, 21, CV_8UC1, cv::Scalar(9)));
  flat.compress();
  EXPECT_EQ(cv::norm(flat.patch(0), cv::Mat(21, 21, CV_8UC1, cv::Scalar(77)), cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(flat.patch(1), cv::Mat(21, 21, CV_8UC1, cv::Scalar(9)), cv::NORM_INF), 0.0);
  PointAppearance none;
  none.compress();
  EXPECT_TRUE(none.empty());
}

TEST(ActiveSearch, CompressedThenExpandedPatchesFindThePointsAsWell) {
  // The rotated, closer view of the test above, searched with patches that were compressed.
  WallScene s = rotatedCloserView();
  const geometry::SE3 prior = perturbedPrior(s);
  const Outcome full = search(s, prior, 0.01);
  for (PointAppearance& appearance : s.appearances) {
    appearance.compress();
    appearance.expand();
  }
  const Outcome quantised = search(s, prior, 0.01);
  ASSERT_GT(quantised.visible, 150);
  EXPECT_GT(quantised.found, 0.95 * full.found);
  EXPECT_LT(quantised.median_error_px, 0.3);
}

TEST(ActiveSearch, HalfResolutionCornersSeedMatchesAsPreciseAsFullResolutionOnes) {
  // The rotated, closer view again, searched from the FAST corners of pyramid level 1 (each
  // within a pixel or two of its full-resolution feature, climbing to the NCC peak) and from
  // those of level 0.
  const WallScene s = rotatedCloserView();
  const geometry::SE3 prior = perturbedPrior(s);
  ActiveSearchParams coarse, full;
  coarse.min_coarse_corner_density = 0.0;  // level 1 whatever its corners
  full.min_coarse_corner_density = 1e9;    // never level 1
  ASSERT_EQ(detectSearchCorners(s.cur, coarse).level(), 1);
  ASSERT_EQ(detectSearchCorners(s.cur, full).level(), 0);
  const Outcome from_level0 = search(s, prior, 0.01, full);
  const Outcome from_level1 = search(s, prior, 0.01, coarse);
  ASSERT_GT(from_level1.visible, 150);
  EXPECT_GE(from_level1.found, 0.9 * from_level0.found);
  EXPECT_LE(from_level1.median_error_px, from_level0.median_error_px + 0.02);
  // Level 1's corners are level-0 pixels inside the border the template needs.
  const CornerGrid coarse_corners = detectSearchCorners(s.cur, coarse);
  for (const cv::KeyPoint& k : coarse_corners.corners()) {
    EXPECT_GE(k.pt.x, coarse.template_radius + 1);
    EXPECT_LT(k.pt.x, s.cur.base().cols - coarse.template_radius - 1);
  }
}

TEST(ActiveSearch, DoesNotMatchOutsideTheRegion) {
  const WallScene s = makeScene(
      geometry::SE3(geometry::expSO3(Eigen::Vector3d(0, 0.02, 0)), Eigen::Vector3d(-0.1, 0, 0)));
  // The prior is 30 px off while claiming to be certain (sigma 1e-4): points must not be found at
  // the wrong place. Some may match a similar-looking corner, but never most of them.
  const geometry::SE3 prior =
      geometry::SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.18, 0, 0)) * s.T_cur_world;
  const Outcome o = search(s, prior, 1e-4);
  EXPECT_LT(o.found, 0.2 * o.visible);
}

TEST(ActiveSearch, WarpMatchesFiniteDifferences) {
  const auto cam = camera();
  const geometry::SE3 T_cur_ref(geometry::expSO3(Eigen::Vector3d(0.1, -0.2, 0.4)),
                                Eigen::Vector3d(0.2, 0.1, -0.3));
  const Eigen::Vector3d p_ref(0.3, -0.2, 2.5);
  const Eigen::Vector3d p_cur = T_cur_ref * p_ref;
  const Eigen::Matrix2d A_ref_cur = referenceWarp(*cam, p_ref, p_cur, T_cur_ref);
  const Eigen::Vector2d u_ref = *cam->project(p_ref), u_cur = *cam->project(p_cur);
  Eigen::Matrix2d A_cur_ref;
  for (int k = 0; k < 2; ++k) {
    const Eigen::Vector2d step = Eigen::Vector2d::Unit(k) * 1e-3;
    const Eigen::Vector3d ray = cam->unproject(u_ref + step);
    const Eigen::Vector3d moved = ray * (p_ref.z() / ray.z());  // same depth
    A_cur_ref.col(k) = (*cam->project(T_cur_ref * moved) - u_cur) / 1e-3;
  }
  EXPECT_LT((A_ref_cur * A_cur_ref - Eigen::Matrix2d::Identity()).norm(), 1e-4);
}

TEST(ActiveSearch, NccIsInvariantToGainAndBias) {
  const float a[] = {1, 5, 3, 8, 2, 9};
  float b[6];
  for (int i = 0; i < 6; ++i)
    b[i] = 2.5f * a[i] + 40.f;
  EXPECT_NEAR(normalizedCrossCorrelation(a, b, 6), 1.0, 1e-9);
  const float flat[] = {4, 4, 4, 4, 4, 4};
  EXPECT_EQ(normalizedCrossCorrelation(a, flat, 6), -1.0);
}

}  // namespace
}  // namespace scale_drift_slam::features
