#pragma once
// Normalised cross-correlation of a small template with an 8-bit image in integer arithmetic:
// active search scores every FAST corner in a search region with it (~17 000 scores per KITTI
// frame), so it is written for SIMD (OpenCV's universal intrinsics), with a scalar path that
// gives the same integers.

#include <array>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace scale_drift_slam::features {

/// A square template of side 2r+1 (r in [1, 7]) made zero-mean with unit norm and stored in
/// fixed point (times kOne), each row padded with zeros to kRowStride values. Scores are exact:
/// the sums are integers (float sums of squares minus the squared sum lost up to 0.03 of a
/// score to rounding).
class FixedPointTemplate {
 public:
  static constexpr int kMaxRadius = 7;
  static constexpr int kRowStride = 16;
  static constexpr double kOne = 16384.0;

  /// From (2r+1)^2 samples in row order; false (and empty) when they have no texture.
  bool set(const std::vector<float>& samples, int radius);
  bool empty() const { return values_.empty(); }
  int radius() const { return radius_; }

  /// NCC with the image patch centred at integer pixel (x, y) of a CV_8UC1 image, in [-1, 1];
  /// -2 when the patch leaves the image, -1 when the patch has no texture.
  double score(const cv::Mat& image, int x, int y) const;
  /// The same score without SIMD (what `score` falls back to at the image's right edge).
  double scoreScalar(const cv::Mat& image, int x, int y) const;

 private:
  double finish(std::int32_t sum_b, std::int32_t sum_bb, std::int32_t sum_tb) const;

  int radius_ = 0;
  std::vector<std::int16_t> values_;  ///< (2r+1) rows of kRowStride, zero past column 2r
  /// -1 in the lanes of a row's columns 0..2r, 0 past them: masks the pixels read with a row.
  alignas(16) std::array<std::int16_t, kRowStride> in_patch_{};
};

}  // namespace scale_drift_slam::features
