// ORB appearance of keyframe images and the geometric check, on procedural views with a known
// homography between them: overlapping views match with correct inliers, unrelated views do not,
// and an identical poster in two different places is refused by the coverage test.

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include "scale_drift_slam/loop/appearance.h"
#include "scale_drift_slam/loop/geometric_check.h"

#include "synthetic_views.h"

namespace scale_drift_slam::loop {
namespace {

using testing::makeTexture;
using testing::renderView;
using testing::ViewPose;

ViewPose at(double x, double y) {
  ViewPose pose;
  pose.x = x;
  pose.y = y;
  return pose;
}

class AppearanceTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { texture_ = new cv::Mat(makeTexture(3000, 900, 21)); }
  static void TearDownTestSuite() { delete texture_; }
  static const cv::Mat& texture() { return *texture_; }
  AppearanceParams params_;
  GeometricCheckParams geometry_;

 private:
  static cv::Mat* texture_;
};
cv::Mat* AppearanceTest::texture_ = nullptr;

TEST_F(AppearanceTest, BoundedCountSpreadOverTheImage) {
  AppearanceExtractor extractor(params_);
  const KeyframeAppearance appearance = extractor.extract(renderView(texture(), at(1000, 450), 1));
  EXPECT_NO_THROW(appearance.validate());
  EXPECT_EQ(appearance.image_width, 640);
  EXPECT_EQ(appearance.image_height, 480);
  EXPECT_GT(appearance.size(), 0.9 * params_.max_features);
  EXPECT_LE(appearance.size(), static_cast<std::size_t>(params_.max_features));
  // Nearly every cell of the spreading grid holds keypoints (a blank cell may not), none more
  // than 3x its fair share.
  std::vector<int> per_cell(static_cast<std::size_t>(params_.grid_cols * params_.grid_rows), 0);
  for (const cv::Point2f& p : appearance.keypoints) {
    const auto row = static_cast<std::size_t>(p.y * params_.grid_rows / 480);
    const auto col = static_cast<std::size_t>(p.x * params_.grid_cols / 640);
    ++per_cell[row * params_.grid_cols + col];
  }
  const double fair = static_cast<double>(appearance.size()) / per_cell.size();
  int empty = 0;
  for (int count : per_cell) {
    empty += count == 0 ? 1 : 0;
    EXPECT_LT(count, 3.0 * fair);
  }
  EXPECT_LE(empty, 2);
}

TEST_F(AppearanceTest, ColourAndGreyImagesGiveTheSameAppearance) {
  AppearanceExtractor extractor(params_);
  const cv::Mat grey = renderView(texture(), at(1500, 450), 2);
  cv::Mat colour;
  cv::cvtColor(grey, colour, cv::COLOR_GRAY2BGR);
  const KeyframeAppearance a = extractor.extract(grey);
  const KeyframeAppearance b = extractor.extract(colour);
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(cv::norm(a.descriptors, b.descriptors, cv::NORM_HAMMING), 0.0);
}

TEST_F(AppearanceTest, RejectsBadImagesAndInconsistentAppearances) {
  AppearanceExtractor extractor(params_);
  EXPECT_THROW(extractor.extract(cv::Mat()), std::invalid_argument);
  EXPECT_THROW(extractor.extract(cv::Mat(480, 640, CV_32FC1, cv::Scalar(0))),
               std::invalid_argument);
  EXPECT_THROW(extractor.extract(cv::Mat(40, 40, CV_8UC1, cv::Scalar(0))), std::invalid_argument);
  // A blank image is valid and has no keypoints.
  const KeyframeAppearance blank = extractor.extract(cv::Mat(480, 640, CV_8UC1, cv::Scalar(90)));
  EXPECT_EQ(blank.size(), 0u);
  EXPECT_NO_THROW(blank.validate());

  KeyframeAppearance appearance = extractor.extract(renderView(texture(), at(1000, 450), 3));
  KeyframeAppearance broken = appearance;
  broken.octaves.pop_back();
  EXPECT_THROW(broken.validate(), std::invalid_argument);
  broken = appearance;
  broken.keypoints[0].x = 700.0f;
  EXPECT_THROW(broken.validate(), std::invalid_argument);
  broken = appearance;
  broken.descriptors = broken.descriptors.colRange(0, 16).clone();
  EXPECT_THROW(broken.validate(), std::invalid_argument);

  AppearanceParams bad = params_;
  bad.min_fast_threshold = bad.fast_threshold + 1;
  EXPECT_THROW(AppearanceExtractor{bad}, std::invalid_argument);
}

TEST_F(AppearanceTest, OverlappingViewsPassWithInliersThatObeyTheTrueHomography) {
  AppearanceExtractor extractor(params_);
  const ViewPose first = at(1000, 450);
  ViewPose second = at(1150, 420);  // 150 px along, rotated, zoomed, tilted, darker
  second.angle_deg = 6.0;
  second.scale = 1.1;
  second.tilt_x = 1e-4;
  second.gain = 0.8;
  second.bias = 20.0;
  const KeyframeAppearance a = extractor.extract(renderView(texture(), first, 4));
  const KeyframeAppearance b = extractor.extract(renderView(texture(), second, 5));
  const GeometricCheckResult result =
      checkGeometry(a, b, matchDescriptors(a, b, geometry_), geometry_);
  EXPECT_TRUE(result.passed) << result.reason;
  EXPECT_GT(result.inliers, 150);
  EXPECT_GT(result.coverage, 0.6);
  // a pixel -> texture -> b pixel.
  const cv::Matx33d H_b_a = testing::viewToTexture(second, cv::Size(640, 480)).inv() *
                            testing::viewToTexture(first, cv::Size(640, 480));
  int correct = 0;
  for (const DescriptorMatch& m : result.inlier_matches) {
    const cv::Point2f& p = a.keypoints[static_cast<std::size_t>(m.query)];
    const cv::Vec3d h = H_b_a * cv::Vec3d(p.x, p.y, 1.0);
    const cv::Point2d predicted(h[0] / h[2], h[1] / h[2]);
    if (cv::norm(predicted - cv::Point2d(b.keypoints[static_cast<std::size_t>(m.candidate)])) <
        4.0) {
      ++correct;
    }
  }
  EXPECT_GT(correct, 0.95 * result.inliers);
}

TEST_F(AppearanceTest, ScaleChangeMeasuresTheZoomBetweenViews) {
  AppearanceExtractor extractor(params_);
  ViewPose zoomed = at(1000, 450);
  zoomed.scale = 1.4;  // the same place seen 1.4 times bigger (from closer)
  const KeyframeAppearance a = extractor.extract(renderView(texture(), at(1000, 450), 11));
  const KeyframeAppearance b = extractor.extract(renderView(texture(), zoomed, 12));
  const GeometricCheckResult result =
      checkGeometry(a, b, matchDescriptors(a, b, geometry_), geometry_);
  ASSERT_GE(result.inliers, geometry_.min_inliers) << result.reason;
  EXPECT_NEAR(result.scale_change, 1.4, 0.05);
  EXPECT_EQ(scaleChange(b, a, {}), 1.0);  // no pair of inliers: no evidence
  GeometricCheckParams strict = geometry_;
  strict.max_scale_change = 1.2;
  strict.min_coverage = 0.0;
  const GeometricCheckResult refused = checkGeometry(a, b, matchDescriptors(a, b, strict), strict);
  EXPECT_FALSE(refused.passed);
  EXPECT_NE(refused.reason.find("scale"), std::string::npos) << refused.reason;
}

TEST_F(AppearanceTest, UndistortedKeypointsRestoreTheTwoViewGeometryOfADistortedLens) {
  geometry::CameraCalibration calibration;
  calibration.fx = calibration.fy = 320.0;
  calibration.cx = 320.0;
  calibration.cy = 240.0;
  calibration.width = 640;
  calibration.height = 480;
  calibration.distortion = {-0.35, 0.12, 0.0, 0.0};  // strong barrel distortion
  const auto camera = geometry::makeCameraModel(calibration);
  const auto unproject = [&](int u, int v) {
    const Eigen::Vector3d ray = camera->unproject(Eigen::Vector2d(u, v));
    return cv::Vec3d(ray.x(), ray.y(), ray.z());
  };
  ViewPose second = at(1130, 450);
  second.angle_deg = 5.0;
  const cv::Mat image_a =
      testing::renderThroughLens(texture(), at(1000, 450), 320, 320, 320, 240, unproject);
  const cv::Mat image_b =
      testing::renderThroughLens(texture(), second, 320, 320, 320, 240, unproject);
  AppearanceExtractor extractor(params_);
  const auto check = [&](const geometry::CameraModel* lens) {
    const KeyframeAppearance a = extractor.extract(image_a, lens);
    const KeyframeAppearance b = extractor.extract(image_b, lens);
    EXPECT_EQ(a.undistorted, lens != nullptr);
    EXPECT_NO_THROW(a.validate());
    return checkGeometry(a, b, matchDescriptors(a, b, geometry_), geometry_);
  };
  const GeometricCheckResult raw = check(nullptr);
  const GeometricCheckResult undistorted = check(camera.get());
  EXPECT_TRUE(undistorted.passed) << undistorted.reason;
  // The texture is a plane: through the ideal pinhole the views differ by a homography.
  EXPECT_EQ(undistorted.model, "homography");
  EXPECT_GT(undistorted.inliers, raw.inliers);

  // Each undistorted keypoint maps back, through the lens, onto the pixel it was found at.
  const KeyframeAppearance distorted = extractor.extract(image_a);
  const KeyframeAppearance ideal = extractor.extract(image_a, camera.get());
  ASSERT_EQ(distorted.size(), ideal.size());  // none beyond 78 degrees with this lens
  for (std::size_t i = 0; i < ideal.size(); i += 50) {
    const Eigen::Vector3d ray((ideal.keypoints[i].x - 320.0) / 320.0,
                              (ideal.keypoints[i].y - 240.0) / 320.0, 1.0);
    const auto pixel = camera->project(ray);
    ASSERT_TRUE(pixel.has_value());
    EXPECT_NEAR(pixel->x(), distorted.keypoints[i].x, 0.05);
    EXPECT_NEAR(pixel->y(), distorted.keypoints[i].y, 0.05);
  }
  geometry::CameraCalibration other = calibration;
  other.width = 320;
  other.cx = 160.0;
  EXPECT_THROW(extractor.extract(image_a, geometry::makeCameraModel(other).get()),
               std::invalid_argument);
}

TEST_F(AppearanceTest, UnrelatedViewsFail) {
  AppearanceExtractor extractor(params_);
  const cv::Mat other = makeTexture(1500, 900, 22);
  const KeyframeAppearance a = extractor.extract(renderView(texture(), at(1000, 450), 6));
  const KeyframeAppearance b = extractor.extract(renderView(other, at(700, 450), 7));
  const KeyframeAppearance c = extractor.extract(renderView(texture(), at(2300, 450), 8));
  EXPECT_FALSE(checkGeometry(a, b, matchDescriptors(a, b, geometry_), geometry_).passed);
  EXPECT_FALSE(checkGeometry(a, c, matchDescriptors(a, c, geometry_), geometry_).passed);
}

TEST_F(AppearanceTest, TheSamePosterInTwoPlacesIsRefusedByCoverage) {
  // Two different walls with one identical poster (a quarter of the view) on each.
  const cv::Mat poster = makeTexture(320, 240, 99);
  cv::Mat wall_a = makeTexture(1500, 900, 23);
  cv::Mat wall_b = makeTexture(1500, 900, 24);
  testing::pastePoster(wall_a, poster, cv::Point(600, 300));
  testing::pastePoster(wall_b, poster, cv::Point(700, 350));
  AppearanceExtractor extractor(params_);
  const KeyframeAppearance a = extractor.extract(renderView(wall_a, at(760, 420), 9));
  ViewPose pose_b = at(900, 500);
  pose_b.angle_deg = 3.0;
  const KeyframeAppearance b = extractor.extract(renderView(wall_b, pose_b, 10));
  const GeometricCheckResult result =
      checkGeometry(a, b, matchDescriptors(a, b, geometry_), geometry_);
  EXPECT_FALSE(result.passed);
  // The poster itself matches well: it is the coverage test that refuses it.
  EXPECT_GE(result.inliers, geometry_.min_inliers);
  EXPECT_LT(result.coverage, geometry_.min_coverage);
  EXPECT_NE(result.reason.find("cover"), std::string::npos) << result.reason;
}

}  // namespace
}  // namespace scale_drift_slam::loop
