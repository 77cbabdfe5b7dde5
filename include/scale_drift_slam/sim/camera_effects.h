#pragma once
// What a real camera adds between the scene and the image its driver delivers, as image-level
// steps that sim::SequenceRenderer chains (doc/sequences.md, "Camera effects"): world-fixed
// sunlight that makes the scene's range exceed the sensor's, defocus, vignetting, an
// auto-exposure controller with lag, and JPEG compression. Each is usable and testable alone.

#include <cstdint>

#include <opencv2/core.hpp>

#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/sim/renderer.h"

namespace scale_drift_slam::sim {

/// Radial brightness fall-off: each pixel times max(0, 1 - k r^2), r its distance from the image
/// centre over the half diagonal (so the corners get 1 - k). In place; 8-bit images round.
void applyVignetting(cv::Mat& image, double k);

/// The point spread function of a lens out of focus: a disc (pillbox) of `radius` pixels, the
/// circle of confusion, normalised to sum 1; pixels on its rim weighted by the area covered.
cv::Mat defocusKernel(double radius);
/// Convolves the image with defocusKernel(radius) (the same blur everywhere: a scene far from
/// the focus distance at every depth). In place; borders reflected.
void applyDefocus(cv::Mat& image, double radius);

/// Encodes the image as JPEG at `quality` (1-100) and decodes it again (mono8 stays mono8, bgr8
/// stays bgr8), as compressed image_transport delivers a camera's frames.
cv::Mat jpegRoundTrip(const cv::Mat& image, int quality);

/// Sunlight fixed in the world: broad patches (metres across, soft 10 cm edges, about a third of
/// every surface) where the radiance is `gain` times the rendered level, and a sky `gain` times
/// as bright, so that a scene spans more than the sensor's range and highlights clip.
class Sunlight {
 public:
  Sunlight(std::uint32_t seed, double gain);
  /// Illumination factor in [1, gain] at a world point.
  float factor(const Eigen::Vector3d& p_world) const;
  /// Radiance of rows `rows` of the last render (8-bit, grey or BGR) into `radiance` (CV_32F with
  /// the image's channels, allocated if needed): levels times the factor of the point each pixel
  /// sees (the renderer's range buffer), `gain` for the background.
  void apply(const Renderer& renderer, const geometry::SE3& T_world_cam, const cv::Mat& image,
             const cv::Range& rows, cv::Mat& radiance) const;

 private:
  Eigen::Vector3f wave_[3];  ///< Direction times 2 pi / wavelength.
  float phase_[3];
  float gain_;
};

/// A camera's auto-exposure: a gain that steers the mean grey level of the delivered (clipped)
/// image towards a target with a first-order lag, as a real controller does (it meters a frame,
/// then corrects the next ones over `time_constant` seconds).
class AutoExposure {
 public:
  explicit AutoExposure(double target = 110.0, double time_constant = 0.25);
  /// Settles the gain on one radiance image as if the camera had been looking at it for long.
  void settle(const cv::Mat& radiance);
  /// Meters a frame taken with the current gain and corrects the gain for the frame `dt` seconds
  /// later.
  void meter(const cv::Mat& radiance, double dt);
  double gain() const { return gain_; }
  void setGain(double gain) { gain_ = gain; }
  /// Mean grey level (over pixels and channels) of radiance * gain clipped at 255.
  static double meteredMean(const cv::Mat& radiance, double gain);

 private:
  double target_, time_constant_;
  double gain_ = 1.0;
};

}  // namespace scale_drift_slam::sim
