// slider: a small camera on a linear slider moving sideways past a wall it faces at close range,
// the case of the Event Camera Dataset's slider sequences (DAVIS240C: 240x180, a 39-degree lens,
// ~22 Hz). The wall (a nature photograph on a board: bark, leaves, rocks at many scales) stands
// 0.3 m in front of the camera, which is still for kStillSeconds, then speeds up smoothly to
// 0.15 m/s and travels 1 m along it without turning: about 10 px of image motion per frame
// across an image 240 px wide, a fronto-parallel plane seen through a narrow lens, where a turn
// about the vertical axis moves the image almost as the slide does. 7 s, 154 frames at 22 Hz.
// Rendered with --sunlight and --auto-exposure (doc/sequences.md) the wall's sunlit patches clip
// and the shade goes dark: the high-dynamic-range version of the real sequence.

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "scale_drift_slam/sim/texture_generator.h"
#include "scenario_builders.h"

namespace scale_drift_slam::sim::detail {
namespace {

constexpr double kStillSeconds = 0.25;  ///< Still for the first ~5 frames, as the real one.
constexpr double kRampSeconds = 0.4;    ///< The slider's motor speeds up over this.
constexpr double kSpeed = 0.15;         ///< m/s once up to speed.
constexpr double kDistance = 0.3;       ///< From the camera to the wall.
constexpr double kWallWidth = 1.6;      ///< x in [-0.3, 1.3]: the view at both ends included.

/// Distance along the slider at time t: 0 while still, then a smooth start to kSpeed.
double slide(double t) {
  const double s = t - kStillSeconds;
  if (s <= 0.0) return 0.0;
  if (s >= kRampSeconds) return kSpeed * (s - 0.5 * kRampSeconds);
  const double u = s / kRampSeconds;
  return kSpeed * kRampSeconds * (u * u * u - 0.5 * u * u * u * u);
}

/// A nature photograph: fractal bark and foliage, darker trunks and brighter stones at random.
cv::Mat naturePhoto(double width_m, double height_m, double tpm, std::uint32_t seed) {
  cv::RNG rng(seed);
  const cv::Size size(static_cast<int>(width_m * tpm), static_cast<int>(height_m * tpm));
  cv::Mat noise = textures::fractalNoise(size, 0.08 * tpm, 7, 0.75, rng);
  cv::Mat image;
  noise.convertTo(image, CV_8U, 70.0, 120.0);
  for (int k = 0; k < static_cast<int>(width_m * 12); ++k) {  // trunks and branches
    const int x = rng.uniform(0, size.width), w = rng.uniform(size.width / 200, size.width / 40);
    cv::rectangle(image, cv::Rect(x, 0, w, size.height), cv::Scalar(rng.uniform(20, 70)),
                  cv::FILLED);
  }
  for (int k = 0; k < static_cast<int>(width_m * 400); ++k) {  // stones and leaves
    const cv::Point c(rng.uniform(0, size.width), rng.uniform(0, size.height));
    const cv::Size axes(rng.uniform(3, size.height / 30), rng.uniform(3, size.height / 30));
    cv::ellipse(image, c, axes, rng.uniform(0.0, 180.0), 0, 360,
                cv::Scalar(rng.uniform(0, 2) ? rng.uniform(170, 240) : rng.uniform(15, 60)),
                cv::FILLED);
  }
  textures::addNoise(image, 25.0, 0.01 * tpm, 3, rng);
  return image;
}

}  // namespace

Scenario makeSlider(std::uint32_t seed) {
  Scenario scenario;
  scenario.name = "slider";
  scenario.description =
      "240x180 camera with a 39-degree lens sliding 1 m sideways past a wall 0.3 m away";
  scenario.duration = 7.0;
  scenario.rate = 22.0;
  scenario.horizontal_fov_deg = 2.0 * std::atan(120.0 / 335.4) * 180.0 / M_PI;  // fx 335
  scenario.distortion = "radtan";
  Scene& scene = scenario.scene;
  scene.background().below = scene.background().zenith = scene.background().horizon = 60.0f;
  const double height = 0.6, tpm = 1400.0;  // ~1.2 texels per pixel at 0.3 m
  // The wall in the plane y = kDistance, seen from y < kDistance; its left end at x = -0.3.
  scene.addQuad({-0.3, kDistance, 0.3}, {kWallWidth, 0, 0}, {0, 0, -height},
                scene.addTexture(naturePhoto(kWallWidth, height, tpm, seed * 16 + 7)), 1.0f);
  scenario.T_world_cam = [](double t) {
    const Eigen::Vector3d position(slide(t), 0.0, 0.0);
    return geometry::SE3(lookRotation(Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ(), 0.0),
                         position);
  };
  return scenario;
}

}  // namespace scale_drift_slam::sim::detail
