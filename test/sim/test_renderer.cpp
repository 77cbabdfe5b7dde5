// The renderer's pixels agree with the ground truth: chessboard corners detected by OpenCV lie
// where the true pose projects them (with and without lens distortion), features tracked between
// two frames of a real scene move as the true poses and ranges predict, and distant fine texture
// is filtered instead of aliased.

#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "scale_drift_slam/sim/renderer.h"
#include "scale_drift_slam/sim/scenario.h"
#include "scale_drift_slam/sim/sequence.h"
#include "scale_drift_slam/sim/texture_generator.h"

namespace scale_drift_slam::sim {
namespace {

geometry::CameraCalibration testCamera(const std::string& distortion) {
  SequenceParams params;
  params.distortion = distortion;
  return sequenceCalibration(params, 70.0);
}

struct CornerErrors {
  int detected = 0;
  double max = 0.0;
  double mean = 0.0;
};

/// A 10 x 7 chessboard (9 x 6 inner corners, 6 cm squares) 0.75 m in front of the camera,
/// tilted; renders it and compares the detected inner corners with their true projections.
CornerErrors chessboardErrors(const std::string& distortion, const geometry::SE3& T_world_cam) {
  const int cols = 10, rows = 7, square_texels = 48;
  const double square = 0.06;
  Scene scene;
  const int texture = scene.addTexture(textures::checkerboard(cols, rows, square_texels));
  const Eigen::Vector3d top_left(-(cols + 2) * square / 2, -(rows + 2) * square / 2, 0.0);
  scene.addQuad(top_left, Eigen::Vector3d((cols + 2) * square, 0, 0),
                Eigen::Vector3d(0, (rows + 2) * square, 0), texture);
  const auto camera = geometry::makeCameraModel(testCamera(distortion));
  Renderer renderer(*camera);
  cv::Mat image;
  renderer.render(scene, T_world_cam.inverse(), image);

  std::vector<cv::Point2f> corners;
  CornerErrors errors;
  if (!cv::findChessboardCorners(image, cv::Size(cols - 1, rows - 1), corners,
                                 cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE)) {
    return errors;
  }
  cv::cornerSubPix(image, corners, cv::Size(5, 5), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-4));
  std::vector<Eigen::Vector2d> truth;
  for (int r = 1; r < rows; ++r) {
    for (int c = 1; c < cols; ++c) {
      // Inner corner (c, r) of the squares lies at texel ((c + 1) * square, (r + 1) * square).
      const Eigen::Vector3d p_world = top_left + Eigen::Vector3d((c + 1) * square, (r + 1) * square, 0);
      const auto pixel = camera->project(T_world_cam.inverse() * p_world);
      if (pixel) truth.push_back(*pixel);
    }
  }
  for (const cv::Point2f& corner : corners) {
    double best = 1e9;
    for (const Eigen::Vector2d& t : truth) best = std::min(best, (t - Eigen::Vector2d(corner.x, corner.y)).norm());
    errors.max = std::max(errors.max, best);
    errors.mean += best / corners.size();
  }
  errors.detected = static_cast<int>(corners.size());
  return errors;
}

geometry::SE3 boardViewpoint(double yaw, double pitch, const Eigen::Vector3d& centre) {
  // The camera looks at the board's centre from 0.75 m, from a direction tilted by yaw/pitch.
  const Eigen::Vector3d direction(std::sin(yaw), std::sin(pitch), -std::cos(yaw) * std::cos(pitch));
  const Eigen::Vector3d position = centre + 0.75 * direction.normalized();
  return geometry::SE3(lookRotation(centre - position, Eigen::Vector3d(0, -1, 0), 0.1), position);
}

TEST(Renderer, ChessboardCornersMatchTheTrueProjection) {
  for (const std::string distortion : {"none", "radtan", "fisheye"}) {
    for (const double yaw : {0.0, 0.35}) {
      const CornerErrors errors = chessboardErrors(distortion, boardViewpoint(yaw, 0.2, {0.02, 0.01, 0}));
      SCOPED_TRACE(distortion + " yaw " + std::to_string(yaw));
      std::printf("chessboard %-8s yaw %.2f: %d corners, max error %.3f px, mean %.3f px\n",
                  distortion.c_str(), yaw, errors.detected, errors.max, errors.mean);
      EXPECT_EQ(errors.detected, 54);
      EXPECT_LT(errors.max, 0.5);
      EXPECT_LT(errors.mean, 0.15);
    }
  }
}

/// Tracks corners between two frames of a scenario with KLT and compares them with the
/// positions predicted from the first frame's range buffer and the two true poses.
double medianFlowError(const std::string& scene_name, const std::string& distortion, double dt,
                       int* tracked) {
  const Scenario scenario = makeScenario(scene_name, 3);
  SequenceParams params;
  params.distortion = distortion;
  const auto camera = geometry::makeCameraModel(sequenceCalibration(params, scenario.horizontal_fov_deg));
  Renderer renderer(*camera);
  const double t0 = 2.0;
  const geometry::SE3 T_w_c0 = scenario.T_world_cam(t0), T_w_c1 = scenario.T_world_cam(t0 + dt);
  cv::Mat image0, image1;
  renderer.render(scenario.scene, T_w_c1.inverse(), image1);
  renderer.render(scenario.scene, T_w_c0.inverse(), image0);  // keep frame 0's range buffer
  const cv::Mat range = renderer.range().clone();
  std::vector<cv::Point2f> corners, moved;
  cv::goodFeaturesToTrack(image0, corners, 300, 0.01, 12, cv::noArray(), 5);
  cv::cornerSubPix(image0, corners, cv::Size(4, 4), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 30, 1e-3));
  std::vector<uchar> status;
  std::vector<float> error;
  cv::calcOpticalFlowPyrLK(image0, image1, corners, moved, status, error, cv::Size(21, 21), 3,
                           cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-3));
  std::vector<double> errors;
  for (size_t i = 0; i < corners.size(); ++i) {
    const int x = static_cast<int>(std::lround(corners[i].x)), y = static_cast<int>(std::lround(corners[i].y));
    if (!status[i] || x < 2 || y < 2 || x >= range.cols - 2 || y >= range.rows - 2) continue;
    // Skip corners on depth edges: their range is ambiguous.
    double lo = 1e9, hi = 0;
    for (int v = -2; v <= 2; ++v) {
      for (int u = -2; u <= 2; ++u) {
        lo = std::min(lo, static_cast<double>(range.at<float>(y + v, x + u)));
        hi = std::max(hi, static_cast<double>(range.at<float>(y + v, x + u)));
      }
    }
    if (!std::isfinite(hi) || hi > 1.03 * lo) continue;
    // The range at the nearest pixel centre, moved to the corner's ray (planar surface).
    const Eigen::Vector3d ray_pixel = camera->unproject(Eigen::Vector2d(x, y)).normalized();
    const Eigen::Vector3d ray = camera->unproject(Eigen::Vector2d(corners[i].x, corners[i].y)).normalized();
    const Eigen::Vector3d p_c0 = ray * (range.at<float>(y, x) * ray_pixel.z() / ray.z());
    const auto predicted = camera->project(T_w_c1.inverse() * (T_w_c0 * p_c0));
    if (!predicted) continue;
    errors.push_back((*predicted - Eigen::Vector2d(moved[i].x, moved[i].y)).norm());
  }
  *tracked = static_cast<int>(errors.size());
  if (errors.empty()) return 1e9;
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  return errors[errors.size() / 2];
}

TEST(Renderer, TrackedFeaturesMoveAsTheGroundTruthPredicts) {
  for (const auto& [scene, distortion] :
       std::vector<std::pair<std::string, std::string>>{{"courtyard_loop", "radtan"},
                                                        {"office_orbit", "none"},
                                                        {"corridor_straight", "fisheye"}}) {
    int tracked = 0;
    const double median = medianFlowError(scene, distortion, 1.0 / 30.0, &tracked);
    SCOPED_TRACE(scene + " " + distortion);
    std::printf("KLT %-18s %-8s: %d corners, median error %.3f px\n", scene.c_str(),
                distortion.c_str(), tracked, median);
    EXPECT_GT(tracked, 80);
    EXPECT_LT(median, 0.3);
  }
}

TEST(Renderer, DistantFineTextureIsFilteredNotAliased) {
  // One-texel stripes (mean 127.5) seen from far away must render as a flat grey.
  cv::Mat stripes(512, 512, CV_8U);
  for (int x = 0; x < 512; ++x) stripes.col(x).setTo(cv::Scalar(x % 2 ? 255 : 0));
  Scene scene;
  scene.addQuad(Eigen::Vector3d(-5, -5, 0), Eigen::Vector3d(10, 0, 0), Eigen::Vector3d(0, 10, 0),
                stripes);
  const auto camera = geometry::makeCameraModel(testCamera("none"));
  Renderer renderer(*camera);
  cv::Mat image;
  const geometry::SE3 T_world_cam(lookRotation(Eigen::Vector3d(0.2, 0.1, -1), Eigen::Vector3d::UnitY()),
                                  Eigen::Vector3d(0, 0, 30));
  renderer.render(scene, T_world_cam.inverse(), image);
  cv::Mat mask = renderer.surfaceIndex() == 0;
  ASSERT_GT(cv::countNonZero(mask), 10000);
  cv::Scalar mean, stddev;
  cv::meanStdDev(image, mean, stddev, mask);
  EXPECT_NEAR(mean[0], 127.5, 4.0);
  EXPECT_LT(stddev[0], 12.0);
}

TEST(Renderer, OcclusionKeepsTheNearerSurface) {
  Scene scene;
  scene.addQuad(Eigen::Vector3d(-1, -1, 0), Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(0, 2, 0),
                cv::Mat(8, 8, CV_8U, cv::Scalar(50)));
  scene.addQuad(Eigen::Vector3d(-0.2, -0.2, 1), Eigen::Vector3d(0.4, 0, 0), Eigen::Vector3d(0, 0.4, 0),
                cv::Mat(8, 8, CV_8U, cv::Scalar(200)));
  const auto camera = geometry::makeCameraModel(testCamera("none"));
  Renderer renderer(*camera);
  cv::Mat image;
  // Camera 3 m above the origin looking down: the small near quad hides the middle of the far one.
  const geometry::SE3 T_world_cam(lookRotation(-Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitY()),
                                  Eigen::Vector3d(0, 0, 3));
  renderer.render(scene, T_world_cam.inverse(), image);
  EXPECT_EQ(image.at<uchar>(camera->height() / 2, camera->width() / 2), 200);
  EXPECT_NEAR(renderer.range().at<float>(camera->height() / 2, camera->width() / 2), 2.0, 1e-3);
  EXPECT_EQ(image.at<uchar>(camera->height() / 2, camera->width() / 2 + 100), 50);
}

TEST(Renderer, RefusesCamerasWiderThanAHalfSphere) {
  SequenceParams params;
  params.distortion = "fisheye";
  params.horizontal_fov_deg = 160;
  params.width = 640;
  params.height = 640;
  const auto camera = geometry::makeCameraModel(sequenceCalibration(params, 80));
  EXPECT_THROW(Renderer renderer(*camera), std::invalid_argument);
}

}  // namespace
}  // namespace scale_drift_slam::sim
