// sphere_flyover: a downward-looking camera flies over a textured sphere (the paper's multi-loop
// simulation). Sphere: radius 8 m at the origin, tessellated into 5-degree latitude-longitude
// cells split into triangles (planar facets: one renderer path with mip-mapping and z-buffer for
// everything; the ground truth is the camera pose, so the 2 cm facet sagitta costs no accuracy).
// Orbit: altitude 4 m, 4.5 m/s, on a great circle tilted 25 degrees from the equator whose plane
// precesses 60 degrees about z per revolution, so every loop crosses the earlier ground tracks:
// three revolutions, 50.3 s, 1507 frames at 30 Hz.

#include <cmath>

#include "scale_drift_slam/sim/texture_generator.h"
#include "scenario_builders.h"

namespace scale_drift_slam::sim::detail {
namespace {

constexpr double kRadius = 8.0;
constexpr double kAltitude = 4.0;
constexpr double kSpeed = 4.5;
constexpr double kTilt = 25.0 * M_PI / 180.0;
constexpr double kPrecession = 1.0 / 6.0;  ///< Turns of the orbit plane per revolution.
constexpr int kRevolutions = 3;

Eigen::Vector3d spherePoint(double longitude, double latitude) {
  return kRadius * Eigen::Vector3d(std::cos(latitude) * std::cos(longitude),
                                   std::cos(latitude) * std::sin(longitude), std::sin(latitude));
}

/// The orbit position at the orbit angle theta.
Eigen::Vector3d orbit(double theta) {
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(kPrecession * theta, Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(kTilt, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  return (kRadius + kAltitude) * (R * Eigen::Vector3d(std::cos(theta), std::sin(theta), 0.0));
}

}  // namespace

Scenario makeSphereFlyover(std::uint32_t seed) {
  Scenario scenario;
  scenario.name = "sphere_flyover";
  scenario.description =
      "downward camera on a precessing orbit, three loops over a textured sphere";
  const double omega = kSpeed / (kRadius + kAltitude);
  scenario.duration = kRevolutions * 2.0 * M_PI / omega;
  scenario.rate = 30.0;
  scenario.horizontal_fov_deg = 80.0;
  Scene& scene = scenario.scene;
  scene.background().zenith = scene.background().horizon = scene.background().below = 15.0f;
  const int texture = scene.addTexture(textures::terrain(2048, seed));
  const Texture& t = scene.texture(texture);
  const int columns = 72, rows = 36;
  for (int j = 0; j < rows; ++j) {
    const double lat0 = M_PI / 2 - M_PI * j / rows, lat1 = M_PI / 2 - M_PI * (j + 1) / rows;
    for (int i = 0; i < columns; ++i) {
      const double lon0 = 2 * M_PI * i / columns, lon1 = 2 * M_PI * (i + 1) / columns;
      const Eigen::Vector2d t00(t.width() * double(i) / columns, t.height() * double(j) / rows);
      const Eigen::Vector2d t10(t.width() * double(i + 1) / columns, t00.y());
      const Eigen::Vector2d t01(t00.x(), t.height() * double(j + 1) / rows);
      const Eigen::Vector2d t11(t10.x(), t01.y());
      const Eigen::Vector3d p00 = spherePoint(lon0, lat0), p10 = spherePoint(lon1, lat0);
      const Eigen::Vector3d p01 = spherePoint(lon0, lat1), p11 = spherePoint(lon1, lat1);
      // Seen from outside, east (+longitude) is to the right and south (down the texture) is
      // downwards, so (east, south) edges keep the texture unmirrored (Surface::double_sided).
      if (j > 0)
        scene.surface(scene.addTriangle(p00, p10, p01, t00, t10, t01, texture)).double_sided =
            false;
      if (j < rows - 1) {
        scene.surface(scene.addTriangle(p11, p01, p10, t11, t01, t10, texture)).double_sided =
            false;
      }
    }
  }
  scenario.T_world_cam = [omega](double time) {
    const double theta = omega * time;
    const Eigen::Vector3d position = orbit(theta);
    const Eigen::Vector3d velocity = (orbit(theta + 1e-4) - orbit(theta - 1e-4)).normalized();
    // Look at the sphere's centre; the flight direction is up in the image.
    return geometry::SE3(lookRotation(-position, velocity), position);
  };
  return scenario;
}

}  // namespace scale_drift_slam::sim::detail
