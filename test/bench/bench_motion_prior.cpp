// The motion prior's optical flow: pyramidal Lucas-Kanade at 200 corners versus OpenCV's dense
// DIS flow sampled at the same corners, on 640x480 renderings of a textured tilted wall with a
// known homography between the frames (so the true flow is exact). Figures: time per frame pair,
// median and 90th-percentile endpoint error, share of points tracked within 1 px. One thread.

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/core.hpp>

#include "../tracking/synthetic_images.h"
#include "bench_report.h"
#include "scale_drift_slam/features/feature_detection.h"
#include "scale_drift_slam/geometry/so3.h"
#include "scale_drift_slam/tracking/optical_flow.h"

using namespace scale_drift_slam;

namespace {

// The homography of the plane n^T x = d (camera-a frame) from camera a to camera b.
Eigen::Matrix3d planeHomography(const Eigen::Matrix3d& K, const geometry::SE3& T_b_a,
                                const Eigen::Vector3d& n_a, double d_a) {
  return K * (T_b_a.rotationMatrix() + T_b_a.translation() * n_a.transpose() / d_a) * K.inverse();
}

}  // namespace

int main(int argc, char** argv) {
  cv::setNumThreads(1);
  bench::Report report("motion_prior", argc, argv);
  const Eigen::Matrix3d K = (Eigen::Matrix3d() << 500, 0, 319.5, 0, 500, 239.5, 0, 0, 1).finished();
  test::TexturedPlane wall;
  wall.texture = test::texturedImage(2000, 1400, 21);
  wall.origin = Eigen::Vector3d(0, 0, 3.0);
  wall.axis_u = Eigen::Vector3d(std::cos(0.3), 0, std::sin(0.3));
  wall.axis_v = Eigen::Vector3d(0, 1, 0);
  wall.metres_per_pixel = 0.004;
  const Eigen::Vector3d n_world = wall.axis_u.cross(wall.axis_v).normalized();
  const double d_world = n_world.dot(wall.origin);

  struct Variant {
    std::string name;
    tracking::OpticalFlowParams params;
  };
  std::vector<Variant> variants;
  for (const auto& [window, levels] :
       {std::pair{21, 4}, std::pair{15, 4}, std::pair{15, 3}, std::pair{11, 4}, std::pair{11, 3}}) {
    tracking::OpticalFlowParams p;
    p.window = window;
    p.pyramid_levels = levels;
    variants.push_back(
        {"lucas_kanade w" + std::to_string(window) + " l" + std::to_string(levels), p});
  }
  // The default window and levels with coarser convergence criteria (the default: 20 iterations,
  // 0.01 px steps), to see what the criterion costs and buys.
  for (const auto& [iterations, step] :
       {std::pair{10, 0.01}, std::pair{20, 0.03}, std::pair{10, 0.03}, std::pair{10, 0.05}}) {
    tracking::OpticalFlowParams p;
    p.max_iterations = iterations;
    p.min_step_px = step;
    char name[64];
    std::snprintf(name, sizeof(name), "lucas_kanade w15 l4 it%d step%.2f", iterations, step);
    variants.push_back({name, p});
  }
  for (int preset = 0; preset <= 2; ++preset) {
    tracking::OpticalFlowParams p;
    p.method = tracking::FlowMethod::kDis;
    p.dis_preset = preset;
    variants.push_back({"dis preset " + std::to_string(preset), p});
  }

  for (const double speed : {1.0, 3.0}) {  // inter-frame motion: ~5 px and ~15 px of flow
    const geometry::SE3 T_a_world;
    const geometry::SE3 T_world_b(
        geometry::expSO3(Eigen::Vector3d(Eigen::Vector3d(0.002, 0.004, 0.001) * speed)),
        Eigen::Vector3d(0.03, -0.01, 0.02) * speed);
    const geometry::SE3 T_b_world = T_world_b.inverse();
    const cv::Mat image_a = test::renderPlanes({wall}, K, T_a_world, 640, 480);
    const cv::Mat image_b = test::renderPlanes({wall}, K, T_b_world, 640, 480);
    const features::ImagePyramid pyr_a = features::buildPyramid(image_a, 4);
    const features::ImagePyramid pyr_b = features::buildPyramid(image_b, 4);
    const Eigen::Matrix3d H = planeHomography(K, T_b_world * T_a_world.inverse(), n_world, d_world);
    std::vector<cv::Point2f> corners;
    for (const auto& k : features::detectSpreadCorners(image_a, 200, {}))
      corners.push_back(k.pt);
    for (Variant& variant : variants) {
      tracking::OpticalFlow flow(variant.params);
      std::vector<cv::Point2f> to;
      std::vector<unsigned char> ok;
      const std::string label = variant.name + ", flow x" + std::to_string(int(speed));
      report.timeMs(label + ": time per frame", 15,
                    [&] { flow.track(pyr_a, pyr_b, corners, &to, &ok); });
      std::vector<double> errors;
      int within = 0;
      for (std::size_t i = 0; i < corners.size(); ++i) {
        const Eigen::Vector2d truth =
            (H * Eigen::Vector3d(corners[i].x, corners[i].y, 1.0)).hnormalized();
        const double e = ok[i] ? (Eigen::Vector2d(to[i].x, to[i].y) - truth).norm() : 1e9;
        errors.push_back(e);
        within += e < 1.0;
      }
      std::sort(errors.begin(), errors.end());
      report.add(label + ": median endpoint error", errors[errors.size() / 2], "px");
      report.add(label + ": 90th percentile endpoint error", errors[errors.size() * 9 / 10], "px");
      report.add(label + ": tracked within 1 px", 100.0 * within / corners.size(), "%");
    }
  }
  return 0;
}
