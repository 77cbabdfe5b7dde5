// corridor_straight: a long forward walk with no revisit (false-loop checks, scale drift). The
// corridor runs along +x from x = -2 m to x = 48 m, 2.6 m wide (y in [-1.3, 1.3]), 2.8 m high;
// its walls are 5 m sections, each generated with its own seed (doors, posters, whiteboards,
// shelves), tiled floor, ceiling panels with lights, posters on both end walls. The camera walks
// from x = 0 to x = 28 m at 1.4 m/s, 1.5 m high, looking ahead with a little sway and head
// rotation. 20 s, 600 frames at 30 Hz.

#include <cmath>

#include "scenario_builders.h"
#include "scale_drift_slam/sim/texture_generator.h"

namespace scale_drift_slam::sim::detail {

Scenario makeCorridorStraight(std::uint32_t seed) {
  Scenario scenario;
  scenario.name = "corridor_straight";
  scenario.description = "forward walk of 28 m along a 50 m corridor, no revisit";
  scenario.duration = 20.0;
  scenario.rate = 30.0;
  scenario.horizontal_fov_deg = 80.0;
  Scene& scene = scenario.scene;
  const double x0 = -2.0, length = 50.0, half_width = 1.3, height = 2.8, section = 5.0;
  const double tpm = 150.0;
  const std::uint32_t base = seed * 128;
  int k = 0;
  for (double x = x0; x < x0 + length - 1e-9; x += section, ++k) {
    // Left wall (y = +half_width) seen from inside: its right points along +x.
    scene.addQuad(Eigen::Vector3d(x, half_width, height), Eigen::Vector3d(section, 0, 0),
                  Eigen::Vector3d(0, 0, -height),
                  textures::interiorWall(section, height, tpm, base + 2 * k, true), 0.92f);
    // Right wall (y = -half_width): its right points along -x.
    scene.addQuad(Eigen::Vector3d(x + section, -half_width, height), Eigen::Vector3d(-section, 0, 0),
                  Eigen::Vector3d(0, 0, -height),
                  textures::interiorWall(section, height, tpm, base + 2 * k + 1, k % 2 == 1), 0.8f);
    scene.addQuad(Eigen::Vector3d(x, half_width, 0), Eigen::Vector3d(section, 0, 0),
                  Eigen::Vector3d(0, -2 * half_width, 0),
                  textures::floorMaterial("tiles", section, 2 * half_width, 100, base + 1000 + k), 0.85f);
    scene.addQuad(Eigen::Vector3d(x, -half_width, height), Eigen::Vector3d(section, 0, 0),
                  Eigen::Vector3d(0, 2 * half_width, 0),
                  textures::floorMaterial("ceiling", section, 2 * half_width, 80, base + 2000 + k), 1.0f);
  }
  cv::RNG rng(seed + 3000);
  for (int end = 0; end < 2; ++end) {
    const double x = end == 0 ? x0 + length : x0;
    const double direction = end == 0 ? -1.0 : 1.0;  // seen from inside
    cv::Mat wall = textures::interiorWall(2 * half_width, height, tpm, base + 3000 + end, false);
    textures::poster(cv::Size(static_cast<int>(1.2 * tpm), static_cast<int>(1.5 * tpm)), rng)
        .copyTo(wall(cv::Rect(static_cast<int>(0.7 * tpm), static_cast<int>(0.5 * tpm),
                              static_cast<int>(1.2 * tpm), static_cast<int>(1.5 * tpm))));
    scene.addQuad(Eigen::Vector3d(x, -direction * half_width, height),
                  Eigen::Vector3d(0, direction * 2 * half_width, 0), Eigen::Vector3d(0, 0, -height),
                  wall, 0.9f);
  }

  const Wobble sway(rng, 0.06, 0.3), bob(rng, 0.02, 1.8), yaw(rng, 0.05, 0.15), pitch(rng, 0.03, 0.2);
  const Wobble roll(rng, 0.02, 0.3);
  scenario.T_world_cam = [=](double t) {
    const Eigen::Vector3d position(1.4 * t, 0.15 + sway(t), 1.5 + bob(t));
    const double a = yaw(t);
    const Eigen::Vector3d look(std::cos(a), std::sin(a), std::tan(pitch(t) - 0.03));
    return geometry::SE3(lookRotation(look, Eigen::Vector3d::UnitZ(), roll(t)), position);
  };
  return scenario;
}

}  // namespace scale_drift_slam::sim::detail
