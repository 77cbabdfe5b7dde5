#include "scale_drift_slam/sim/camera_effects.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace scale_drift_slam::sim {

void applyVignetting(cv::Mat& image, double k) {
  if (k == 0) return;
  const double cx = 0.5 * (image.cols - 1), cy = 0.5 * (image.rows - 1);
  const double half_diagonal_sq =
      0.25 * (double(image.cols) * image.cols + double(image.rows) * image.rows);
  cv::Mat falloff(image.size(), CV_32F);
  for (int y = 0; y < image.rows; ++y) {
    float* row = falloff.ptr<float>(y);
    for (int x = 0; x < image.cols; ++x) {
      const double r_sq = ((x - cx) * (x - cx) + (y - cy) * (y - cy)) / half_diagonal_sq;
      row[x] = static_cast<float>(std::max(0.0, 1.0 - k * r_sq));
    }
  }
  if (image.channels() > 1) cv::merge(std::vector<cv::Mat>(image.channels(), falloff), falloff);
  const int type = image.type();
  cv::Mat as_float;
  image.convertTo(as_float, CV_32F);
  cv::multiply(as_float, falloff, as_float);
  as_float.convertTo(image, type);
}

cv::Mat defocusKernel(double radius) {
  if (!(radius > 0)) return cv::Mat::ones(1, 1, CV_32F);
  const int half = static_cast<int>(std::ceil(radius - 0.5));
  const int size = 2 * half + 1;
  constexpr int kSub = 8;  // sub-samples per pixel side: the rim's area coverage
  cv::Mat kernel(size, size, CV_32F);
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      int inside = 0;
      for (int sy = 0; sy < kSub; ++sy) {
        for (int sx = 0; sx < kSub; ++sx) {
          const double dx = x - half - 0.5 + (sx + 0.5) / kSub;
          const double dy = y - half - 0.5 + (sy + 0.5) / kSub;
          inside += dx * dx + dy * dy <= radius * radius;
        }
      }
      kernel.at<float>(y, x) = static_cast<float>(inside);
    }
  }
  return kernel / cv::sum(kernel)[0];
}

void applyDefocus(cv::Mat& image, double radius) {
  if (!(radius > 0)) return;
  cv::filter2D(image, image, -1, defocusKernel(radius), cv::Point(-1, -1), 0,
               cv::BORDER_REFLECT_101);
}

cv::Mat jpegRoundTrip(const cv::Mat& image, int quality) {
  if (quality < 1 || quality > 100) throw std::invalid_argument("JPEG quality must be in [1, 100]");
  std::vector<std::uint8_t> bytes;
  if (!cv::imencode(".jpg", image, bytes, {cv::IMWRITE_JPEG_QUALITY, quality})) {
    throw std::runtime_error("JPEG encoding failed");
  }
  return cv::imdecode(bytes, image.channels() == 1 ? cv::IMREAD_GRAYSCALE : cv::IMREAD_COLOR);
}

Sunlight::Sunlight(std::uint32_t seed, double gain) : gain_(static_cast<float>(gain)) {
  cv::RNG rng(seed * 2654435761ULL + 99);
  for (int k = 0; k < 3; ++k) {
    Eigen::Vector3f direction(static_cast<float>(rng.gaussian(1.0)),
                              static_cast<float>(rng.gaussian(1.0)),
                              static_cast<float>(rng.gaussian(1.0)));
    const double wavelength = rng.uniform(3.0, 6.0);  // metres: patches ~1-3 m across
    wave_[k] = direction.normalized() * static_cast<float>(2.0 * M_PI / wavelength);
    phase_[k] = static_cast<float>(rng.uniform(0.0, 2.0 * M_PI));
  }
}

float Sunlight::factor(const Eigen::Vector3d& p_world) const {
  const Eigen::Vector3f p = p_world.cast<float>();
  float f = 0.0f;
  for (int k = 0; k < 3; ++k)
    f += std::sin(wave_[k].dot(p) + phase_[k]);
  // Lit where the sum of the three waves exceeds 0.6 (about a third of the points), with a soft
  // edge (|grad f| ~ 1.5 / m: ~10 cm penumbra).
  const float s = std::clamp((f - 0.6f) / 0.15f + 0.5f, 0.0f, 1.0f);
  const float smooth = s * s * (3.0f - 2.0f * s);
  return 1.0f + (gain_ - 1.0f) * smooth;
}

void Sunlight::apply(const Renderer& renderer, const geometry::SE3& T_world_cam,
                     const cv::Mat& image, const cv::Range& rows, cv::Mat& radiance) const {
  const int channels = image.channels();
  radiance.create(image.size(), CV_32FC(channels));
  const cv::Mat& index = renderer.surfaceIndex();
  const Eigen::Matrix3d R = T_world_cam.rotationMatrix();
  const Eigen::Vector3d& t = T_world_cam.translation();
  for (int y = rows.start; y < rows.end; ++y) {
    const std::uint8_t* in = image.ptr<std::uint8_t>(y);
    float* out = radiance.ptr<float>(y);
    const int* surface = index.ptr<int>(y);
    for (int x = 0; x < image.cols; ++x) {
      const float light =
          surface[x] < 0 ? gain_ : factor(R * renderer.point(x, y).cast<double>() + t);
      for (int c = 0; c < channels; ++c)
        out[x * channels + c] = in[x * channels + c] * light;
    }
  }
}

AutoExposure::AutoExposure(double target, double time_constant)
    : target_(target), time_constant_(time_constant) {}

double AutoExposure::meteredMean(const cv::Mat& radiance, double gain) {
  cv::Mat clipped;
  cv::threshold(radiance * gain, clipped, 255.0, 255.0, cv::THRESH_TRUNC);
  const cv::Scalar mean = cv::mean(clipped);
  double sum = 0;
  for (int c = 0; c < radiance.channels(); ++c)
    sum += mean[c];
  return sum / radiance.channels();
}

void AutoExposure::settle(const cv::Mat& radiance) {
  gain_ = 1.0;
  if (radiance.empty()) return;
  for (int iteration = 0; iteration < 8; ++iteration) {
    gain_ *= target_ / std::max(1.0, meteredMean(radiance, gain_));
  }
}

void AutoExposure::meter(const cv::Mat& radiance, double dt) {
  const double measured = std::max(1.0, meteredMean(radiance, gain_));
  // First-order lag in the log of the gain: a step in brightness is 63 % corrected after
  // time_constant seconds.
  const double alpha = 1.0 - std::exp(-dt / time_constant_);
  gain_ = std::clamp(gain_ * std::pow(target_ / measured, alpha), 1e-3, 1e3);
}

}  // namespace scale_drift_slam::sim
