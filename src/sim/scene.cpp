#include "scale_drift_slam/sim/scene.h"

#include <stdexcept>

namespace scale_drift_slam::sim {

int Scene::addTexture(const cv::Mat& image) {
  textures_.push_back(std::make_shared<const Texture>(image));
  return static_cast<int>(textures_.size()) - 1;
}

int Scene::addQuad(const Eigen::Vector3d& top_left, const Eigen::Vector3d& right,
                   const Eigen::Vector3d& down, int texture, float gain) {
  Surface surface;
  surface.origin = top_left;
  surface.edge1 = right;
  surface.edge2 = down;
  surface.texture = texture;
  const Texture& t = this->texture(texture);
  surface.texel_axes << t.width(), 0.0, 0.0, t.height();
  surface.gain = gain;
  return addSurface(surface);
}

int Scene::addQuad(const Eigen::Vector3d& top_left, const Eigen::Vector3d& right,
                   const Eigen::Vector3d& down, const cv::Mat& image, float gain) {
  return addQuad(top_left, right, down, addTexture(image), gain);
}

int Scene::addTriangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                       const Eigen::Vector2d& texel_a, const Eigen::Vector2d& texel_b,
                       const Eigen::Vector2d& texel_c, int texture, float gain) {
  Surface surface;
  surface.shape = Surface::Shape::kTriangle;
  surface.origin = a;
  surface.edge1 = b - a;
  surface.edge2 = c - a;
  surface.texture = texture;
  surface.texel_origin = texel_a;
  surface.texel_axes.col(0) = texel_b - texel_a;
  surface.texel_axes.col(1) = texel_c - texel_a;
  surface.gain = gain;
  return addSurface(surface);
}

int Scene::addSurface(const Surface& surface) {
  if (surface.texture < 0 || surface.texture >= textureCount()) {
    throw std::invalid_argument("surface refers to a missing texture");
  }
  if (!surface.origin.allFinite() || !surface.edge1.allFinite() || !surface.edge2.allFinite() ||
      !surface.texel_axes.allFinite() || !surface.texel_origin.allFinite()) {
    throw std::invalid_argument("surface with a non-finite coordinate");
  }
  if (surface.edge1.cross(surface.edge2).norm() < 1e-12) {
    throw std::invalid_argument("degenerate surface (parallel or zero edges)");
  }
  // The renderer reads at most half a texel outside the texture: every corner's texel must lie
  // inside it.
  const Texture& t = texture(surface.texture);
  const Eigen::Vector2d corners[4] = {{0, 0}, {1, 0}, {0, 1}, {1, 1}};
  for (int k = 0; k < (surface.shape == Surface::Shape::kTriangle ? 3 : 4); ++k) {
    const Eigen::Vector2d texel = surface.texel_origin + surface.texel_axes * corners[k];
    if (texel.x() < -1e-6 || texel.y() < -1e-6 || texel.x() > t.width() + 1e-6 ||
        texel.y() > t.height() + 1e-6) {
      throw std::invalid_argument("surface maps outside its texture");
    }
  }
  surfaces_.push_back(surface);
  return static_cast<int>(surfaces_.size()) - 1;
}

}  // namespace scale_drift_slam::sim
