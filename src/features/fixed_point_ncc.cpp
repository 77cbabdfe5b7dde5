#include "scale_drift_slam/features/fixed_point_ncc.h"

#include <cmath>
#include <stdexcept>

#include <opencv2/core/hal/intrin.hpp>

namespace scale_drift_slam::features {

bool FixedPointTemplate::set(const std::vector<float>& samples, int radius) {
  const int side = 2 * radius + 1;
  if (radius < 1 || radius > kMaxRadius || static_cast<int>(samples.size()) != side * side) {
    throw std::invalid_argument("FixedPointTemplate: need (2r+1)^2 samples with r in [1, 7]");
  }
  values_.clear();
  radius_ = radius;
  for (int i = 0; i < kRowStride; ++i)
    in_patch_[i] = i <= 2 * radius ? -1 : 0;
  double sum = 0.0;
  for (const float v : samples)
    sum += v;
  const double mean = sum / samples.size();
  double norm_sq = 0.0;
  for (const float v : samples)
    norm_sq += (v - mean) * (v - mean);
  if (norm_sq < 1e-6 * samples.size()) return false;
  const double scale = kOne / std::sqrt(norm_sq);
  values_.assign(static_cast<std::size_t>(side) * kRowStride, 0);
  for (int row = 0; row < side; ++row) {
    for (int col = 0; col < side; ++col) {
      // Rounded half away from zero, as std::lround, which is a library call.
      const double v = (samples[row * side + col] - mean) * scale;
      values_[row * kRowStride + col] = static_cast<std::int16_t>(
          v >= 0.0 ? static_cast<int>(v + 0.5) : -static_cast<int>(0.5 - v));
    }
  }
  return true;
}

// sum t b / sqrt(sum b^2 - (sum b)^2 / n): t has zero mean and norm kOne.
double FixedPointTemplate::finish(std::int32_t sum_b, std::int32_t sum_bb,
                                  std::int32_t sum_tb) const {
  const double n = static_cast<double>((2 * radius_ + 1) * (2 * radius_ + 1));
  const double variance = sum_bb - static_cast<double>(sum_b) * sum_b / n;
  if (variance < 1e-3 * n) return -1.0;
  return sum_tb / (kOne * std::sqrt(variance));
}

double FixedPointTemplate::scoreScalar(const cv::Mat& image, int x, int y) const {
  const int r = radius_;
  if (values_.empty() || x < r || y < r || x + r >= image.cols || y + r >= image.rows) return -2.0;
  // At most 225 pixels of 255 and sum |t| <= kOne * 15: every sum stays far below 2^31.
  std::int32_t sb = 0, sbb = 0, stb = 0;
  for (int dy = -r; dy <= r; ++dy) {
    const unsigned char* row = image.ptr<unsigned char>(y + dy) + x - r;
    const std::int16_t* t = values_.data() + (dy + r) * kRowStride;
    for (int dx = 0; dx <= 2 * r; ++dx) {
      const std::int32_t b = row[dx];
      sb += b;
      sbb += b * b;
      stb += t[dx] * b;
    }
  }
  return finish(sb, sbb, stb);
}

double FixedPointTemplate::score(const cv::Mat& image, int x, int y) const {
#if CV_SIMD128
  const int r = radius_;
  // A row is read as 16 bytes from its first pixel: only where they all lie on the image row.
  if (values_.empty() || x < r || y < r || x - r + kRowStride > image.cols || y + r >= image.rows) {
    return scoreScalar(image, x, y);
  }
  // A row's 16 lanes hold pixels 0..15 from its first pixel; only those up to 2r belong to
  // the patch (the template is zero past them, the pixels are masked).
  const cv::v_int16x8 low_mask = cv::v_load_aligned(in_patch_.data());
  const cv::v_int16x8 high_mask = cv::v_load_aligned(in_patch_.data() + 8);
  cv::v_int32x4 sum_tb = cv::v_setzero_s32(), sum_bb = cv::v_setzero_s32();
  cv::v_int16x8 sum_b = cv::v_setzero_s16();  // <= 15 rows * 2 * 255 per lane
  for (int dy = -r; dy <= r; ++dy) {
    const cv::v_uint8x16 pixels = cv::v_load(image.ptr<unsigned char>(y + dy) + x - r);
    cv::v_uint16x8 low16, high16;
    cv::v_expand(pixels, low16, high16);
    const cv::v_int16x8 low = cv::v_reinterpret_as_s16(low16) & low_mask;
    const cv::v_int16x8 high = cv::v_reinterpret_as_s16(high16) & high_mask;
    const std::int16_t* t = values_.data() + (dy + r) * kRowStride;
    sum_tb += cv::v_dotprod(low, cv::v_load(t)) + cv::v_dotprod(high, cv::v_load(t + 8));
    sum_bb += cv::v_dotprod(low, low) + cv::v_dotprod(high, high);
    sum_b += low + high;
  }
  cv::v_int32x4 sum_b_low, sum_b_high;
  cv::v_expand(sum_b, sum_b_low, sum_b_high);
  return finish(cv::v_reduce_sum(sum_b_low + sum_b_high), cv::v_reduce_sum(sum_bb),
                cv::v_reduce_sum(sum_tb));
#else
  return scoreScalar(image, x, y);
#endif
}

}  // namespace scale_drift_slam::features
