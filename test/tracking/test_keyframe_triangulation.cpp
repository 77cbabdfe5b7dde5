// Keyframe triangulation (tracking/keyframe_triangulation.h) on rendered views of a textured wall
// at a known depth: corners of a keyframe matched by ORB along the epipolar lines of an earlier
// keyframe 30 cm away are triangulated onto the wall; a camera that only turns gives no point
// (no parallax); pixels taken by map points or candidates are left alone.

#include <algorithm>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "scale_drift_slam/geometry/so3.h"
#include "scale_drift_slam/tracking/keyframe_triangulation.h"
#include "synthetic_images.h"

namespace scale_drift_slam::tracking {
namespace {

constexpr double kWallDepth = 3.0;
constexpr double kFocal = 500.0;

test::TexturedPlane wall() {
  test::TexturedPlane p;
  p.texture = test::texturedImage(2400, 1600, 77);
  p.origin = Eigen::Vector3d(0, 0, kWallDepth);
  p.axis_u = Eigen::Vector3d(1, 0, 0);
  p.axis_v = Eigen::Vector3d(0, 1, 0);
  p.metres_per_pixel = 0.004;
  return p;
}

/// T_cam_world of a camera at `x` metres sideways, turned by `yaw` radians.
geometry::SE3 pose(double x, double yaw) {
  return geometry::SE3(geometry::expSO3(Eigen::Vector3d(0, yaw, 0)), Eigen::Vector3d(x, 0, 0))
      .inverse();
}

features::ImagePyramid render(const geometry::SE3& T_cam_world) {
  return features::buildPyramid(
      test::renderPlanes({wall()}, test::pinholeCamera(kFocal)->K(), T_cam_world, 640, 480), 4, 15);
}

/// At least `at_least` relative depth errors against the wall, the median within 1 % and 90 %
/// within 5 % (what the alignment gives on the clear wall).
void expectOnTheWall(std::vector<double> errors, std::size_t at_least) {
  ASSERT_GT(errors.size(), at_least);
  std::sort(errors.begin(), errors.end());
  EXPECT_LT(errors[errors.size() / 2], 0.01);
  EXPECT_LT(errors[static_cast<std::size_t>(0.9 * errors.size())], 0.05);
}

KeyframeTriangulation::PoseLookup posesOf(std::vector<geometry::SE3> poses) {
  return [poses](map::KeyframeId id) -> std::optional<geometry::SE3> {
    if (id >= poses.size()) return std::nullopt;
    return poses[id];
  };
}

TEST(KeyframeTriangulation, MatchesAcrossAWideBaselineLandOnTheWall) {
  const auto camera = test::pinholeCamera(kFocal);
  // 30 cm at 3 m (5.7 degrees of parallax) and a 4-degree turn: ~50-80 px of image motion.
  const std::vector<geometry::SE3> poses = {pose(0.0, 0.0), pose(0.3, 0.07)};
  KeyframeTriangulation triangulation(KeyframeTriangulationParams{},
                                      features::FeatureDetectionParams{}, kFocal);
  EXPECT_TRUE(triangulation.addKeyframe(0, poses[0], render(poses[0]), {}, *camera, posesOf(poses))
                  .empty());
  const std::vector<TriangulatedPoint> points =
      triangulation.addKeyframe(1, poses[1], render(poses[1]), {}, *camera, posesOf(poses));
  EXPECT_GT(points.size(), 100u);
  // Each match is aligned by Lucas-Kanade onto the new keyframe's patch before triangulation
  // (FAST corners sit on whole pixels): measured 0.05 % median, 0.15 % at 90 %, 0.3 % at worst.
  std::vector<double> errors;
  for (const TriangulatedPoint& p : points) {
    EXPECT_EQ(p.other, 0u);
    errors.push_back(std::abs(p.p_world.z() - kWallDepth) / kWallDepth);
    // The observations are where the point projects (normalised coordinates).
    const Eigen::Vector3d in_new = poses[1] * p.p_world, in_old = poses[0] * p.p_world;
    EXPECT_LT(kFocal * (in_new.head<2>() / in_new.z() - p.xy).norm(), 2.5);
    EXPECT_LT(kFocal * (in_old.head<2>() / in_old.z() - p.other_xy).norm(), 2.5);
  }
  std::sort(errors.begin(), errors.end());
  ASSERT_FALSE(errors.empty());
  EXPECT_LT(errors[errors.size() / 2], 0.01);                              // median depth error
  EXPECT_LT(errors[static_cast<std::size_t>(0.9 * errors.size())], 0.05);  // 90 % within 5 %
  EXPECT_LT(errors.back(), 0.25);
}

TEST(KeyframeTriangulation, ACameraThatOnlyTurnsMakesNoPoint) {
  const auto camera = test::pinholeCamera(kFocal);
  const std::vector<geometry::SE3> poses = {pose(0.0, 0.0), pose(0.001, 0.08)};
  KeyframeTriangulation triangulation(KeyframeTriangulationParams{},
                                      features::FeatureDetectionParams{}, kFocal);
  triangulation.addKeyframe(0, poses[0], render(poses[0]), {}, *camera, posesOf(poses));
  EXPECT_TRUE(triangulation.addKeyframe(1, poses[1], render(poses[1]), {}, *camera, posesOf(poses))
                  .empty());
}

TEST(KeyframeTriangulation, LeavesOccupiedPixelsAndForgottenKeyframesAlone) {
  const auto camera = test::pinholeCamera(kFocal);
  const std::vector<geometry::SE3> poses = {pose(0.0, 0.0), pose(0.3, 0.07)};
  std::vector<Eigen::Vector2d> left_half;  // taken by map points and candidates
  for (int y = 0; y < 480; y += 8) {
    for (int x = 0; x < 320; x += 8)
      left_half.emplace_back(x, y);
  }
  KeyframeTriangulation triangulation(KeyframeTriangulationParams{},
                                      features::FeatureDetectionParams{}, kFocal);
  triangulation.addKeyframe(0, poses[0], render(poses[0]), {}, *camera, posesOf(poses));
  const std::vector<TriangulatedPoint> points =
      triangulation.addKeyframe(1, poses[1], render(poses[1]), left_half, *camera, posesOf(poses));
  EXPECT_GT(points.size(), 30u);
  for (const TriangulatedPoint& p : points)
    EXPECT_GT(p.px.x(), 320.0);
  // A keyframe the map no longer holds (a restart, a lookup that fails) is not matched with.
  KeyframeTriangulation forgetful(KeyframeTriangulationParams{}, features::FeatureDetectionParams{},
                                  kFocal);
  forgetful.addKeyframe(0, poses[0], render(poses[0]), {}, *camera, posesOf(poses));
  EXPECT_TRUE(
      forgetful.addKeyframe(1, poses[1], render(poses[1]), {}, *camera, posesOf({})).empty());
}

// Texture fixed to the sensor (a saturated sensor's fixed pattern, dust, a burnt-in overlay) sits
// at the same pixels in both keyframes. A camera that slides sideways and turns against the slide
// has nearly horizontal epipolar lines, so each such corner about the horizon lies on its own
// epipolar line, matches itself by descriptor, and the turn gives it parallax: 10 of them were
// triangulated (at the depth where the slide undoes the turn), map points that hold a pose still.
TEST(KeyframeTriangulation, TextureFixedToTheSensorMakesNoPoint) {
  const auto camera = test::pinholeCamera(kFocal);
  const std::vector<geometry::SE3> poses = {pose(0.0, 0.0), pose(0.3, -0.07)};
  const cv::Rect patch(20, 180, 200, 120);  // about the horizon: on its own epipolar line
  const cv::Mat fixed = test::texturedImage(patch.width, patch.height, 5);
  const auto render_with_patch = [&](const geometry::SE3& T_cam_world) {
    cv::Mat image =
        test::renderPlanes({wall()}, test::pinholeCamera(kFocal)->K(), T_cam_world, 640, 480);
    fixed.copyTo(image(patch));
    return features::buildPyramid(image, 4, 15);
  };
  KeyframeTriangulation triangulation(KeyframeTriangulationParams{},
                                      features::FeatureDetectionParams{}, kFocal);
  triangulation.addKeyframe(0, poses[0], render_with_patch(poses[0]), {}, *camera, posesOf(poses));
  const std::vector<TriangulatedPoint> points = triangulation.addKeyframe(
      1, poses[1], render_with_patch(poses[1]), {}, *camera, posesOf(poses));
  // A corner on the patch's edge is half wall, half patch: neither counted nor checked.
  const cv::Rect inside(patch.x + 4, patch.y + 4, patch.width - 8, patch.height - 8);
  const cv::Rect edge(patch.x - 8, patch.y - 8, patch.width + 16, patch.height + 16);
  int on_patch = 0;
  std::vector<double> errors;
  for (const TriangulatedPoint& p : points) {
    const cv::Point2d px(p.px.x(), p.px.y());
    on_patch += inside.contains(px);
    if (!edge.contains(px)) errors.push_back(std::abs(p.p_world.z() - kWallDepth) / kWallDepth);
  }
  EXPECT_EQ(on_patch, 0);       // 10 before
  expectOnTheWall(errors, 60);  // the wall's points are made as before
}

// Where the scene is nearly flat (a saturated part of the view) a sensor's fixed pattern, brought
// out by the contrast stretch, dominates the pixels: a corner of the scene there moves with the
// camera and is matched (ORB looks at the smoothed image), but its 9x9 patch is the sensor's and
// is found again unchanged at the same pixel, where active search then holds the pose still. Such
// corners make no point; the wall's clear part is triangulated as before.
TEST(KeyframeTriangulation, ACornerWhosePatchIsTheSensorsPatternMakesNoPoint) {
  const auto camera = test::pinholeCamera(kFocal);
  const std::vector<geometry::SE3> poses = {pose(0.0, 0.0), pose(0.3, 0.07)};
  const cv::Rect faint(0, 0, 280, 480);
  cv::Mat pattern(faint.size(), CV_32F);
  cv::RNG(3).fill(pattern, cv::RNG::NORMAL, 0.0, 10.0);  // per pixel, the same in every frame
  const auto render_with_pattern = [&](const geometry::SE3& T_cam_world) {
    cv::Mat image =
        test::renderPlanes({wall()}, test::pinholeCamera(kFocal)->K(), T_cam_world, 640, 480);
    cv::Mat part;
    image(faint).convertTo(part, CV_32F);
    part = 128.0 + 0.2 * (part - 128.0) + pattern;  // a fifth of the wall's contrast
    part.convertTo(image(faint), CV_8U);
    return features::buildPyramid(image, 4, 15);
  };
  const features::ImagePyramid first = render_with_pattern(poses[0]);
  const features::ImagePyramid second = render_with_pattern(poses[1]);
  KeyframeTriangulation triangulation(KeyframeTriangulationParams{},
                                      features::FeatureDetectionParams{}, kFocal);
  triangulation.addKeyframe(0, poses[0], first, {}, *camera, posesOf(poses));
  const std::vector<TriangulatedPoint> points =
      triangulation.addKeyframe(1, poses[1], second, {}, *camera, posesOf(poses));
  int patterned = 0;
  std::vector<double> errors;
  for (const TriangulatedPoint& p : points) {
    if (p.px.x() > faint.width + 8) {
      errors.push_back(std::abs(p.p_world.z() - kWallDepth) / kWallDepth);
      continue;
    }
    // The point's patch against the same pixel of the first keyframe.
    cv::Mat a, b, ncc;
    const cv::Point2f at(static_cast<float>(p.px.x()), static_cast<float>(p.px.y()));
    cv::getRectSubPix(second.base(), cv::Size(9, 9), at, a);
    cv::getRectSubPix(first.base(), cv::Size(9, 9), at, b);
    cv::matchTemplate(a, b, ncc, cv::TM_CCOEFF_NORMED);
    patterned += ncc.at<float>(0, 0) > 0.8f;
  }
  EXPECT_EQ(patterned, 0);  // 2 before
  expectOnTheWall(errors, 40);
}

TEST(KeyframeTriangulation, EpipolarDistanceIsZeroForATrueMatchAndGrowsOffTheLine) {
  const geometry::SE3 T_a_world = pose(0.0, 0.0), T_b_world = pose(0.3, 0.07);
  const Eigen::Vector3d p(0.2, -0.1, 3.0);
  const Eigen::Vector3d in_a = T_a_world * p, in_b = T_b_world * p;
  const Eigen::Vector2d xy_a = in_a.head<2>() / in_a.z(), xy_b = in_b.head<2>() / in_b.z();
  const geometry::SE3 T_b_a = T_b_world * T_a_world.inverse();
  EXPECT_LT(epipolarDistancePx(T_b_a, xy_a, xy_b, kFocal), 1e-6);
  // Moved 10 px across the (nearly horizontal) epipolar line: ~10 px away.
  EXPECT_NEAR(epipolarDistancePx(T_b_a, xy_a, xy_b + Eigen::Vector2d(0, 10 / kFocal), kFocal), 10.0,
              0.5);
  const std::optional<Eigen::Vector3d> x = triangulateMidpoint(T_a_world, xy_a, T_b_world, xy_b);
  ASSERT_TRUE(x);
  EXPECT_LT((*x - p).norm(), 1e-9);
}

}  // namespace
}  // namespace scale_drift_slam::tracking
