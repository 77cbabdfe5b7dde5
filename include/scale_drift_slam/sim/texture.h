#pragma once
// A mip-mapped grey-level texture for the renderer (sim/renderer.h). Level 0 is the full image,
// each further level halves it by area averaging. Sampling blends the two levels around the
// requested level of detail where it lies in the middle third between them and takes the nearer
// level elsewhere ("brilinear": continuous, a third of the work of trilinear filtering), so
// distant surfaces do not alias.

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace scale_drift_slam::sim {

/// An immutable texture pyramid. Built once when a scene is made, then only read (safe to share
/// between threads); not copyable (its layout points into its own buffer). Texel coordinates are
/// those of level 0, texel i covering [i, i + 1).
class Texture {
 public:
  static constexpr int kMaxLevels = 16;

  /// The pyramid as flat arrays (also for vectorised sampling): every level with a one-texel
  /// replicated border in one buffer; texel (x, y) of level l, for x in [-1, width_l] and y in
  /// [-1, height_l], at pool[offset[l] + y * stride[l] + x]; the buffer ends with spare bytes so
  /// that a 32-bit load at any texel stays inside.
  struct Layout {
    const std::uint8_t* pool = nullptr;
    int levels = 0;
    float max_lod = 0.0f;  ///< levels - 1.
    std::int32_t offset[kMaxLevels] = {};
    std::int32_t stride[kMaxLevels] = {};
    float scale_x[kMaxLevels] = {};  ///< Level texels per level-0 texel.
    float scale_y[kMaxLevels] = {};
  };

  /// Takes an 8-bit grey image (at least 2x2, at most 2^30 texels) and builds the pyramid down
  /// to about 2x2 (at most kMaxLevels levels). Throws std::invalid_argument otherwise.
  explicit Texture(const cv::Mat& image);
  Texture(const Texture&) = delete;
  Texture& operator=(const Texture&) = delete;

  int width() const { return images_[0].cols; }
  int height() const { return images_[0].rows; }
  int levelCount() const { return layout_.levels; }
  const cv::Mat& level(int i) const { return images_.at(static_cast<size_t>(i)); }
  const Layout& layout() const { return layout_; }

  /// The grey level at texel coordinates (u, v) of level 0 for a pixel footprint of 2^lod
  /// level-0 texels (lod <= 1/3: level 0). (u, v) may lie up to half a texel outside the texture.
  float sample(float u, float v, float lod) const {
    if (lod <= 1.0f / 3.0f) return bilinear(0, u, v);
    if (lod >= layout_.max_lod) return bilinear(layout_.levels - 1, u, v);
    const int l = static_cast<int>(lod);
    const float f = lod - static_cast<float>(l);
    if (f < 1.0f / 3.0f) return bilinear(l, u, v);
    if (f > 2.0f / 3.0f) return bilinear(l + 1, u, v);
    const float a = bilinear(l, u, v);
    const float b = bilinear(l + 1, u, v);
    return a + (3.0f * f - 1.0f) * (b - a);
  }

 private:
  /// Bilinear interpolation between texel centres (texel i has its centre at i + 0.5), in
  /// integers with 1/256-texel weights (exact to 0.004 texel). The offset by 65536 makes the
  /// conversion a floor, so x in [-1, width] needs only the one-texel border.
  float bilinear(int l, float u, float v) const {
    const int xi = static_cast<int>((u * layout_.scale_x[l] - 0.5f) * 256.0f + 65536.0f) - 65536;
    const int yi = static_cast<int>((v * layout_.scale_y[l] - 0.5f) * 256.0f + 65536.0f) - 65536;
    const int fx = xi & 255, fy = yi & 255;
    const std::uint8_t* row0 =
        layout_.pool + layout_.offset[l] + (yi >> 8) * layout_.stride[l] + (xi >> 8);
    const std::uint8_t* row1 = row0 + layout_.stride[l];
    const int top = (row0[0] << 8) + (row0[1] - row0[0]) * fx;
    const int bottom = (row1[0] << 8) + (row1[1] - row1[0]) * fx;
    return static_cast<float>((top << 8) + (bottom - top) * fy) * (1.0f / 65536.0f);
  }

  std::vector<cv::Mat> images_;     ///< The levels without border.
  std::vector<std::uint8_t> pool_;  ///< All levels with their borders (see Layout).
  Layout layout_;
};

}  // namespace scale_drift_slam::sim
