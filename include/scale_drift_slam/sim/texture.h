#pragma once
// A mip-mapped grey-level texture for the renderer (sim/renderer.h). Level 0 is the full image,
// each further level halves it by area averaging; sampling is trilinear (bilinear in the two
// levels around the requested level of detail, blended), so distant surfaces do not alias.

#include <cmath>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace scale_drift_slam::sim {

/// An immutable texture pyramid. Built once when a scene is made, then only read (safe to share
/// between threads). Texel coordinates are those of level 0, texel i covering [i, i + 1).
class Texture {
 public:
  /// Takes an 8-bit grey image (at least 2x2) and builds the pyramid down to about 2x2.
  /// Throws std::invalid_argument for another type or a smaller image.
  explicit Texture(const cv::Mat& image);

  int width() const { return images_[0].cols; }
  int height() const { return images_[0].rows; }
  int levelCount() const { return static_cast<int>(levels_.size()); }
  const cv::Mat& level(int i) const { return images_[static_cast<size_t>(i)]; }

  /// The grey level at texel coordinates (u, v) of level 0 for a pixel footprint of 2^lod
  /// level-0 texels (lod <= 0: magnification, bilinear in level 0). Clamps at the borders.
  /// Trilinear where the level of detail lies in the middle third between two levels, bilinear
  /// in the nearer level elsewhere ("brilinear": a third of the work of trilinear filtering on
  /// average; the blend stays continuous). Coordinates may
  /// lie up to half a texel outside the texture (a replicated border is kept around each level).
  float sample(float u, float v, float lod) const {
    if (lod <= 1.0f / 3.0f) return bilinear(levels_[0], u, v);
    if (lod >= max_lod_) return bilinear(levels_.back(), u, v);
    const int l = static_cast<int>(lod);
    const float f = lod - static_cast<float>(l);
    if (f < 1.0f / 3.0f) return bilinear(levels_[static_cast<size_t>(l)], u, v);
    if (f > 2.0f / 3.0f) return bilinear(levels_[static_cast<size_t>(l) + 1], u, v);
    const float a = bilinear(levels_[static_cast<size_t>(l)], u, v);
    const float b = bilinear(levels_[static_cast<size_t>(l) + 1], u, v);
    return a + 3.0f * (f - 1.0f / 3.0f) * (b - a);
  }

 private:
  struct Level {
    const std::uint8_t* data = nullptr;  ///< Texel (0, 0); one replicated texel around.
    std::size_t stride = 0;
    float scale_x = 1.0f;  ///< Level texels per level-0 texel.
    float scale_y = 1.0f;
  };

  /// Bilinear interpolation between texel centres (texel i has its centre at i + 0.5), in
  /// integers with 1/256-texel weights (exact to 0.004 texel). The arithmetic shift floors
  /// negative coordinates, so x in [-1, width] needs only the one-texel border.
  static float bilinear(const Level& level, float u, float v) {
    const int xi = static_cast<int>((u * level.scale_x - 0.5f) * 256.0f + 65536.0f) - 65536;
    const int yi = static_cast<int>((v * level.scale_y - 0.5f) * 256.0f + 65536.0f) - 65536;
    const int fx = xi & 255, fy = yi & 255;
    const std::uint8_t* row0 = level.data + static_cast<std::ptrdiff_t>(yi >> 8) *
                                                static_cast<std::ptrdiff_t>(level.stride) +
                               (xi >> 8);
    const std::uint8_t* row1 = row0 + level.stride;
    const int top = (row0[0] << 8) + (row0[1] - row0[0]) * fx;
    const int bottom = (row1[0] << 8) + (row1[1] - row1[0]) * fx;
    return static_cast<float>((top << 8) + (bottom - top) * fy) * (1.0f / 65536.0f);
  }

  std::vector<cv::Mat> padded_;  ///< Each level with a one-texel replicated border.
  float max_lod_ = 0.0f;
  std::vector<cv::Mat> images_;
  std::vector<Level> levels_;
};

}  // namespace scale_drift_slam::sim
