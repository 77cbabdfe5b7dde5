#pragma once
// Test helpers: a reproducible textured image (random rectangles and discs on a smooth
// gradient), corner-rich like a real scene, for the image-based tracking tests.

#include <cmath>
#include <memory>
#include <random>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "scale_drift_slam/geometry/camera_model.h"
#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/geometry/so3.h"

namespace scale_drift_slam::test {

/// An undistorted 640x480 pinhole camera with the principal point at the image centre.
inline std::shared_ptr<const geometry::CameraModel> pinholeCamera(double focal_length_px) {
  geometry::CameraCalibration c;
  c.fx = c.fy = focal_length_px;
  c.cx = 319.5;
  c.cy = 239.5;
  c.width = 640;
  c.height = 480;
  return geometry::makeCameraModel(c);
}

/// Frame k of a smooth sideways sweep with a slow turn through boxRoom(4, 2, 4), looking at its
/// far wall (T_world_cam).
inline geometry::SE3 sweepPose(int k) {
  const double t = 0.04 * k;
  const Eigen::Vector3d centre(1.2 * std::sin(t), 0.2 * std::sin(0.7 * t), -1.0 + 0.3 * t);
  return geometry::SE3(
      geometry::expSO3(Eigen::Vector3d(0.05 * std::sin(0.5 * t), 0.25 * std::sin(t), 0.0)), centre);
}

inline cv::Mat texturedImage(int width, int height, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> grey(20, 235);
  cv::Mat image(height, width, CV_8UC1);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      image.at<unsigned char>(y, x) = static_cast<unsigned char>(100 + 50 * x / width);
    }
  }
  std::uniform_real_distribution<double> ux(0, width), uy(0, height), size(4, 30);
  const int shapes = width * height / 500;
  for (int i = 0; i < shapes; ++i) {
    const cv::Point center(static_cast<int>(ux(rng)), static_cast<int>(uy(rng)));
    const int s = static_cast<int>(size(rng));
    if (i % 2 == 0) {
      cv::rectangle(image, center, center + cv::Point(s, s * 2 / 3), cv::Scalar(grey(rng)), -1);
    } else {
      cv::circle(image, center, s / 2, cv::Scalar(grey(rng)), -1, cv::LINE_AA);
    }
  }
  cv::GaussianBlur(image, image, cv::Size(3, 3), 0.8);
  return image;
}

}  // namespace scale_drift_slam::test

#include <vector>

#include <Eigen/Core>
#include <Eigen/LU>

#include "scale_drift_slam/geometry/se3.h"

namespace scale_drift_slam::test {

/// A textured rectangle in the world: texture pixel (u, v) sits at
/// origin + (u - w/2) * metres_per_pixel * axis_u + (v - h/2) * metres_per_pixel * axis_v.
struct TexturedPlane {
  cv::Mat texture;
  Eigen::Vector3d origin;
  Eigen::Vector3d axis_u, axis_v;  ///< Orthonormal.
  double metres_per_pixel = 0.01;
};

/// Renders the planes (painter's order: list the far ones first) into a pinhole image with
/// intrinsics K, through the homography K [R a_u s, R a_v s, R o' + t] of each plane.
inline cv::Mat renderPlanes(const std::vector<TexturedPlane>& planes, const Eigen::Matrix3d& K,
                            const geometry::SE3& T_cam_world, int width, int height) {
  cv::Mat image(height, width, CV_8UC1, cv::Scalar(0));
  for (const TexturedPlane& plane : planes) {
    const Eigen::Matrix3d R = T_cam_world.rotationMatrix();
    const double s = plane.metres_per_pixel;
    const Eigen::Vector3d corner = plane.origin - 0.5 * plane.texture.cols * s * plane.axis_u -
                                   0.5 * plane.texture.rows * s * plane.axis_v;
    Eigen::Matrix3d M;
    M.col(0) = R * plane.axis_u * s;
    M.col(1) = R * plane.axis_v * s;
    M.col(2) = R * corner + T_cam_world.translation();
    const Eigen::Matrix3d H = K * M;
    cv::Mat Hcv(3, 3, CV_64F);
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c)
        Hcv.at<double>(r, c) = H(r, c);
    }
    cv::Mat warped, mask;
    cv::warpPerspective(plane.texture, warped, Hcv, image.size(), cv::INTER_LINEAR);
    cv::warpPerspective(cv::Mat(plane.texture.size(), CV_8UC1, cv::Scalar(255)), mask, Hcv,
                        image.size(), cv::INTER_NEAREST);
    // Only where the pixel's ray meets the plane in front of the camera: n.(t d) = c, t > 0.
    const Eigen::Vector3d n = R * plane.axis_u.cross(plane.axis_v);
    const double c = n.dot(R * plane.origin + T_cam_world.translation());
    const Eigen::Matrix3d K_inv = K.inverse();
    for (int v = 0; v < height; ++v) {
      unsigned char* row = mask.ptr<unsigned char>(v);
      for (int u = 0; u < width; ++u) {
        if (c * n.dot(K_inv * Eigen::Vector3d(u, v, 1.0)) <= 0.0) row[u] = 0;
      }
    }
    warped.copyTo(image, mask);
  }
  return image;
}

}  // namespace scale_drift_slam::test

namespace scale_drift_slam::test {

/// The inside of a textured box (a room): x in [-hx, hx], y in [-hy, hy] (y down), z in [-hz, hz].
inline std::vector<TexturedPlane> boxRoom(double hx, double hy, double hz, unsigned seed) {
  const double s = 0.006;
  auto face = [&](Eigen::Vector3d origin, Eigen::Vector3d u, Eigen::Vector3d v, double w, double h,
                  unsigned k) {
    TexturedPlane p;
    p.texture = texturedImage(static_cast<int>(w / s), static_cast<int>(h / s), seed + k);
    p.origin = origin;
    p.axis_u = u;
    p.axis_v = v;
    p.metres_per_pixel = s;
    return p;
  };
  const Eigen::Vector3d X = Eigen::Vector3d::UnitX(), Y = Eigen::Vector3d::UnitY(),
                        Z = Eigen::Vector3d::UnitZ();
  return {face(Eigen::Vector3d(0, 0, hz), X, Y, 2 * hx, 2 * hy, 0),
          face(Eigen::Vector3d(0, 0, -hz), X, Y, 2 * hx, 2 * hy, 1),
          face(Eigen::Vector3d(hx, 0, 0), Z, Y, 2 * hz, 2 * hy, 2),
          face(Eigen::Vector3d(-hx, 0, 0), Z, Y, 2 * hz, 2 * hy, 3),
          face(Eigen::Vector3d(0, hy, 0), X, Z, 2 * hx, 2 * hz, 4),
          face(Eigen::Vector3d(0, -hy, 0), X, Z, 2 * hx, 2 * hz, 5)};
}

}  // namespace scale_drift_slam::test
