#pragma once
// What place recognition needs of a keyframe image: ORB keypoints spread over the image and
// their 256-bit descriptors. Compact (about 41 bytes per keypoint) so that the keyframe message
// carries it and the loop-closure side never needs the raw image.

#include <cstdint>
#include <cstring>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include "scale_drift_slam/geometry/camera_model.h"
#include "scale_drift_slam/loop/place_recognition_params.h"

namespace scale_drift_slam::loop {

/// Bytes of one ORB descriptor (256 bits). The vocabulary and the matcher assume it.
constexpr int kDescriptorBytes = 32;

/// Keypoints and descriptors of one keyframe image. Row i of `descriptors` (CV_8UC1,
/// n x kDescriptorBytes) describes keypoint i. Keypoints are pixels of the image it was computed
/// on or, when `undistorted`, pixels of the ideal pinhole camera with the same fx, fy, cx, cy
/// (lens distortion removed, so that the two-view geometry of the geometric check holds; they may
/// then lie a little outside the image).
struct KeyframeAppearance {
  int image_width = 0;
  int image_height = 0;
  bool undistorted = false;
  std::vector<cv::Point2f> keypoints;
  std::vector<std::uint8_t> octaves;  ///< ORB pyramid level of each keypoint.
  cv::Mat descriptors;

  std::size_t size() const { return keypoints.size(); }
  /// Throws std::invalid_argument when the parts disagree (sizes, descriptor type or width, a
  /// non-finite keypoint, a keypoint outside the image unless undistorted, a non-positive image
  /// size).
  void validate() const;
  /// The descriptor of keypoint i as kDescriptorBytes bytes.
  const std::uint8_t* descriptor(std::size_t i) const { return descriptors.ptr<std::uint8_t>(i); }
};

/// Computes KeyframeAppearance from grey images. Owns an OpenCV ORB detector; not thread-safe:
/// use one per thread (the tracking thread, when it drops a keyframe).
class AppearanceExtractor {
 public:
  /// Throws std::invalid_argument when the params are invalid.
  explicit AppearanceExtractor(const AppearanceParams& params);

  /// Detects up to max_features ORB keypoints spread over the grid and describes them. Accepts
  /// CV_8UC1 (or CV_8UC3 / CV_8UC4, converted to grey). Throws std::invalid_argument for an
  /// empty image, another depth, or an image too small for the ORB border. With a camera,
  /// keypoints are undistorted (KeyframeAppearance::undistorted) and those more than 78 degrees
  /// off the optical axis dropped; the camera's image size must equal the image's.
  KeyframeAppearance extract(const cv::Mat& image, const geometry::CameraModel* camera = nullptr);

  const AppearanceParams& params() const { return params_; }

 private:
  std::vector<cv::KeyPoint> detectSpread(const cv::Mat& grey);

  AppearanceParams params_;
  cv::Ptr<cv::ORB> orb_;
};

/// Put on a function whose inner loop is Hamming distances: on x86-64 GCC compiles it twice, for
/// CPUs with the popcnt instruction (it turns bitCount into one) and for the others, and the
/// loader picks one for the CPU it runs on (function multi-versioning). The same distances,
/// 2.7x faster; Debian's baseline (x86-64 without popcnt) is kept.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#define SDS_HAMMING_LOOP __attribute__((target_clones("popcnt", "default")))
#else
#define SDS_HAMMING_LOOP
#endif

/// Bits set in a 64-bit word, by the parallel bit count (Hacker's Delight, sec. 5-1): portable
/// and twice as fast as __builtin_popcountll without -mpopcnt (bench_place_recognition).
inline int bitCount(std::uint64_t x) {
  x = x - ((x >> 1) & 0x5555555555555555ull);
  x = (x & 0x3333333333333333ull) + ((x >> 2) & 0x3333333333333333ull);
  x = (x + (x >> 4)) & 0x0f0f0f0f0f0f0f0full;
  return static_cast<int>((x * 0x0101010101010101ull) >> 56);
}

/// Hamming distance of two 256-bit descriptors.
inline int hammingDistance(const std::uint8_t* a, const std::uint8_t* b) {
  int distance = 0;
  for (int i = 0; i < kDescriptorBytes; i += 8) {
    std::uint64_t x = 0;
    std::uint64_t y = 0;
    std::memcpy(&x, a + i, 8);
    std::memcpy(&y, b + i, 8);
    distance += bitCount(x ^ y);
  }
  return distance;
}

}  // namespace scale_drift_slam::loop
