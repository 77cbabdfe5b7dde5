#pragma once
// Test scenes with known answers for the mapping tests: cameras sliding sideways in front of a
// box of points, exact projections plus Gaussian pixel noise, fixed seeds.

#include <random>
#include <vector>

#include <Eigen/Core>

#include "scale_drift_slam/geometry/se3.h"

namespace scale_drift_slam::testing {

struct Scene {
  std::vector<geometry::SE3> T_cam_world;  ///< Cameras along x, looking along +z.
  std::vector<Eigen::Vector3d> points;     ///< In a box 3..7 m ahead.
};

inline Scene makeScene(int num_cameras, int num_points, double spacing, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Scene scene;
  for (int i = 0; i < num_cameras; ++i) {
    geometry::SE3::Tangent xi;
    xi << 0.02 * u(rng), 0.02 * u(rng), 0.02 * u(rng), 0.0, 0.0, 0.0;
    const geometry::SE3 R = geometry::SE3::exp(xi);
    const Eigen::Vector3d centre(spacing * i, 0.05 * u(rng), 0.05 * u(rng));
    scene.T_cam_world.push_back(geometry::SE3(R.rotation(), -(R.rotation() * centre)));
  }
  const double mid = spacing * (num_cameras - 1) / 2.0;
  for (int j = 0; j < num_points; ++j) {
    scene.points.emplace_back(mid + 3.0 * u(rng), 1.5 * u(rng), 5.0 + 2.0 * u(rng));
  }
  return scene;
}

inline Eigen::Vector2d project(const geometry::SE3& T_cam_world, const Eigen::Vector3d& p) {
  const Eigen::Vector3d y = T_cam_world * p;
  return y.head<2>() / y.z();
}

/// The projection if it lies within the half field of view `half_fov` (normalised units).
inline bool visible(const geometry::SE3& T_cam_world, const Eigen::Vector3d& p, double half_fov) {
  const Eigen::Vector3d y = T_cam_world * p;
  return y.z() > 0.1 && std::abs(y.x() / y.z()) < half_fov && std::abs(y.y() / y.z()) < half_fov;
}

inline geometry::SE3 perturb(const geometry::SE3& T, double rotation, double translation,
                             std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  geometry::SE3::Tangent xi;
  xi << rotation * n(rng), rotation * n(rng), rotation * n(rng), translation * n(rng),
      translation * n(rng), translation * n(rng);
  return geometry::SE3::exp(xi) * T;
}

inline double positionError(const geometry::SE3& a, const geometry::SE3& b) {
  return (a.inverseTranslation() - b.inverseTranslation()).norm();
}

}  // namespace scale_drift_slam::testing
