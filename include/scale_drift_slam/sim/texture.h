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

  int width() const { return levels_[0].width; }
  int height() const { return levels_[0].height; }
  int levelCount() const { return static_cast<int>(levels_.size()); }
  const cv::Mat& level(int i) const { return images_[static_cast<size_t>(i)]; }

  /// The grey level at texel coordinates (u, v) of level 0 for a pixel footprint of 2^lod
  /// level-0 texels (lod <= 0: magnification, bilinear in level 0). Clamps at the borders.
  float sample(float u, float v, float lod) const {
    if (lod <= 0.0f) return bilinear(levels_[0], u, v);
    const float max_lod = static_cast<float>(levels_.size() - 1);
    if (lod >= max_lod) return bilinear(levels_.back(), u, v);
    const int l = static_cast<int>(lod);
    const float f = lod - static_cast<float>(l);
    const float a = bilinear(levels_[static_cast<size_t>(l)], u, v);
    if (f < 1.0f / 64.0f) return a;
    const float b = bilinear(levels_[static_cast<size_t>(l) + 1], u, v);
    return a + f * (b - a);
  }

 private:
  struct Level {
    const std::uint8_t* data = nullptr;
    int width = 0;
    int height = 0;
    std::size_t stride = 0;
    float scale_x = 1.0f;  ///< Level texels per level-0 texel.
    float scale_y = 1.0f;
    float max_x = 0.0f;  ///< Largest clamped coordinate (keeps x0 + 1 inside the image).
    float max_y = 0.0f;
  };

  /// Bilinear interpolation between texel centres (texel i has its centre at i + 0.5).
  static float bilinear(const Level& level, float u, float v) {
    float x = u * level.scale_x - 0.5f;
    float y = v * level.scale_y - 0.5f;
    x = x < 0.0f ? 0.0f : (x > level.max_x ? level.max_x : x);
    y = y < 0.0f ? 0.0f : (y > level.max_y ? level.max_y : y);
    const int x0 = static_cast<int>(x);
    const int y0 = static_cast<int>(y);
    const float fx = x - static_cast<float>(x0);
    const float fy = y - static_cast<float>(y0);
    const std::uint8_t* row0 = level.data + static_cast<std::size_t>(y0) * level.stride + x0;
    const std::uint8_t* row1 = row0 + level.stride;
    const float top = row0[0] + fx * (static_cast<float>(row0[1]) - row0[0]);
    const float bottom = row1[0] + fx * (static_cast<float>(row1[1]) - row1[0]);
    return top + fy * (bottom - top);
  }

  std::vector<cv::Mat> images_;
  std::vector<Level> levels_;
};

}  // namespace scale_drift_slam::sim
