#pragma once
// A synthetic world for the renderer: textured planar surfaces (parallelograms and triangles) in
// metres, world frame z up, plus a background (sky) for rays that hit nothing.

#include <memory>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "scale_drift_slam/sim/texture.h"

namespace scale_drift_slam::sim {

/// One planar textured surface. Its points are X = origin + b1 edge1 + b2 edge2 with
/// (b1, b2) in [0,1]^2 (parallelogram) or b1, b2 >= 0, b1 + b2 <= 1 (triangle); the texel at X is
/// texel_origin + texel_axes (b1, b2) in level-0 texel coordinates of its texture.
struct Surface {
  enum class Shape { kParallelogram, kTriangle };
  Shape shape = Shape::kParallelogram;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d edge1 = Eigen::Vector3d::UnitX();
  Eigen::Vector3d edge2 = Eigen::Vector3d::UnitY();
  int texture = 0;  ///< Index into Scene::textures().
  Eigen::Vector2d texel_origin = Eigen::Vector2d::Zero();
  Eigen::Matrix2d texel_axes = Eigen::Matrix2d::Identity();
  float gain = 1.0f;                       ///< Brightness factor (illumination of this surface).
  Eigen::Vector3f tint{1.0f, 1.0f, 1.0f};  ///< B, G, R factors for colour output.
  /// False: visible only from the front, where the texture is not mirrored (edge1 to the right,
  /// edge2 downwards), i.e. invisible from the side that edge1 x edge2 points to.
  bool double_sided = true;
  /// Not drawn (a moving object out of the world at the time rendered).
  bool hidden = false;
};

/// Grey level of rays that hit no surface, as a function of the ray's elevation in the world
/// (z up): a sky brightening towards the horizon, a darker ground below it.
struct Background {
  float zenith = 150.0f;
  float horizon = 215.0f;
  float below = 60.0f;
  Eigen::Vector3f tint{1.25f, 1.0f, 0.85f};
  float level(double elevation_sine) const {
    if (elevation_sine < 0.0) return below;
    return horizon + (zenith - horizon) * static_cast<float>(elevation_sine);
  }
};

/// The scene: owns its textures (shared, immutable) and surfaces. Built once, then read-only (the
/// renderer only reads it; safe to render from several threads with one Renderer each).
class Scene {
 public:
  /// Adds a texture and returns its index. Throws std::invalid_argument for a non-grey image.
  int addTexture(const cv::Mat& image);
  const Texture& texture(int index) const { return *textures_.at(static_cast<size_t>(index)); }
  int textureCount() const { return static_cast<int>(textures_.size()); }

  /// Adds a rectangle (or parallelogram) showing the whole texture: `top_left` is the texture's
  /// top-left corner, `right` the edge along the texture's rows, `down` the edge along its
  /// columns. Returns the surface index.
  int addQuad(const Eigen::Vector3d& top_left, const Eigen::Vector3d& right,
              const Eigen::Vector3d& down, int texture, float gain = 1.0f);
  /// Adds a rectangle with a new texture image (convenience for addTexture + addQuad).
  int addQuad(const Eigen::Vector3d& top_left, const Eigen::Vector3d& right,
              const Eigen::Vector3d& down, const cv::Mat& image, float gain = 1.0f);
  /// Adds a triangle with texel coordinates at its three corners.
  int addTriangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                  const Eigen::Vector2d& texel_a, const Eigen::Vector2d& texel_b,
                  const Eigen::Vector2d& texel_c, int texture, float gain = 1.0f);
  /// Adds any surface (validated: finite, non-degenerate, existing texture).
  int addSurface(const Surface& surface);

  const std::vector<Surface>& surfaces() const { return surfaces_; }
  Surface& surface(int index) { return surfaces_.at(static_cast<size_t>(index)); }
  Background& background() { return background_; }
  const Background& background() const { return background_; }

 private:
  std::vector<std::shared_ptr<const Texture>> textures_;
  std::vector<Surface> surfaces_;
  Background background_;
};

}  // namespace scale_drift_slam::sim
