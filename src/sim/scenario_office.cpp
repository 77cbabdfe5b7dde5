// office_orbit: a hand-held camera in a furnished room (TUM fr1/desk-like: short, wobbly, some
// rotation). Room 6 m x 5 m x 2.7 m (x in [-3, 3], y in [-2.5, 2.5]); a desk with a monitor, a
// keyboard and papers, cabinets, a bookshelf, boxes. The camera swings on an arc of about 1.7 m
// radius around the desk (+-43 degrees, height 1.33-1.57 m), looking at it with hand shake.
// 20 s, 600 frames at 30 Hz. office_pan (scenario_office_pan.cpp) pans in the same room.

#include <cmath>

#include "scale_drift_slam/sim/texture_generator.h"
#include "scenario_builders.h"

namespace scale_drift_slam::sim::detail {

Eigen::Vector3d addOfficeRoom(Scene& scene, std::uint32_t seed) {
  scene.background().below = scene.background().zenith = scene.background().horizon = 40.0f;
  const double tpm = 200.0, height = 2.7;
  const std::uint32_t base = seed * 64;
  const Eigen::Vector3d corners[4] = {{-3, -2.5, 0}, {3, -2.5, 0}, {3, 2.5, 0}, {-3, 2.5, 0}};
  const float gains[4] = {0.95f, 0.85f, 1.0f, 0.8f};
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector3d right = corners[k] - corners[(k + 1) % 4];
    const int index = scene.addQuad(
        corners[(k + 1) % 4] + Eigen::Vector3d(0, 0, height), right, Eigen::Vector3d(0, 0, -height),
        textures::interiorWall(right.norm(), height, tpm, base + k, k % 2 == 0), gains[k]);
    scene.surface(index).tint = Eigen::Vector3f(0.9f + 0.05f * k, 1.0f, 1.1f - 0.05f * k);
  }
  scene.addQuad(Eigen::Vector3d(-3, 2.5, 0), Eigen::Vector3d(6, 0, 0), Eigen::Vector3d(0, -5, 0),
                textures::floorMaterial("carpet", 6, 5, 120, base + 10), 0.8f);
  scene.addQuad(Eigen::Vector3d(-3, -2.5, height), Eigen::Vector3d(6, 0, 0),
                Eigen::Vector3d(0, 5, 0), textures::floorMaterial("ceiling", 6, 5, 100, base + 11),
                1.0f);
  // Furniture.
  const Eigen::Vector3d desk(0.3, 0.4, 0.0);
  addBox(scene, desk, {1.6, 0.8, 0.75}, 0.0,
         textures::furniture("cabinet", 1.6, 0.75, tpm, base + 20),
         textures::furniture("desk", 1.6, 0.8, 300, base + 21));
  addBox(scene, desk + Eigen::Vector3d(0.1, 0.22, 0.75), {0.56, 0.05, 0.36}, 0.0,
         textures::furniture("screen", 0.56, 0.36, 500, base + 22),
         textures::floorMaterial("carpet", 0.56, 0.05, 200, base + 23), 0.9f);
  addBox(scene, {-2.6, 0.0, 0.0}, {0.6, 1.6, 1.1}, 0.0,
         textures::furniture("cabinet", 1.6, 1.1, tpm, base + 24),
         textures::furniture("desk", 0.6, 1.6, tpm, base + 25));
  addBox(scene, {2.75, -1.2, 0.0}, {0.4, 1.2, 1.9}, 0.0,
         textures::furniture("books", 1.2, 1.9, tpm, base + 26),
         textures::floorMaterial("wood", 0.4, 1.2, tpm, base + 27));
  addBox(scene, {-1.3, 1.9, 0.0}, {0.5, 0.4, 0.45}, 0.3,
         textures::furniture("cabinet", 0.5, 0.45, tpm, base + 28),
         textures::furniture("desk", 0.5, 0.4, tpm, base + 29));
  addBox(scene, {1.6, 1.6, 0.0}, {0.7, 0.5, 0.8}, -0.2,
         textures::furniture("books", 0.7, 0.8, tpm, base + 30),
         textures::furniture("screen", 0.7, 0.5, tpm, base + 31));
  addBox(scene, desk + Eigen::Vector3d(0.2, -0.75, 0.0), {0.45, 0.45, 0.5}, 0.15,
         textures::floorMaterial("carpet", 0.45, 0.5, tpm, base + 32),
         textures::floorMaterial("carpet", 0.45, 0.45, tpm, base + 33), 0.7f);

  return desk;
}

Scenario makeOfficeOrbit(std::uint32_t seed) {
  Scenario scenario;
  scenario.name = "office_orbit";
  scenario.description = "hand-held camera swinging around a desk in a furnished 6 m x 5 m room";
  scenario.duration = 20.0;
  scenario.rate = 30.0;
  scenario.horizontal_fov_deg = 65.0;  // like the TUM RGB-D Kinect
  const Eigen::Vector3d desk = addOfficeRoom(scenario.scene, seed);
  cv::RNG rng(seed + 1000);
  const Wobble shake_x(rng, 0.012, 1.5), shake_y(rng, 0.012, 1.7), shake_z(rng, 0.01, 1.3);
  const Wobble look_x(rng, 0.12, 0.2), look_y(rng, 0.1, 0.25), look_z(rng, 0.08, 0.3);
  const Wobble roll(rng, 0.05, 0.3);
  const Eigen::Vector3d centre = desk + Eigen::Vector3d(0, 0, 0.8);
  scenario.T_world_cam = [=](double t) {
    const double phi =
        -0.5 * M_PI + 0.6 * std::sin(2 * M_PI * t / 16.0) + 0.15 * std::sin(2 * M_PI * t / 5.3);
    const double radius = 1.7 + 0.2 * std::sin(2 * M_PI * t / 9.0);
    const Eigen::Vector3d position =
        Eigen::Vector3d(centre.x() + radius * std::cos(phi), centre.y() + radius * std::sin(phi),
                        1.45 + 0.12 * std::sin(2 * M_PI * t / 7.0)) +
        Eigen::Vector3d(shake_x(t), shake_y(t), shake_z(t));
    const Eigen::Vector3d target = centre + Eigen::Vector3d(look_x(t), look_y(t), look_z(t));
    return geometry::SE3(lookRotation(target - position, Eigen::Vector3d::UnitZ(), roll(t)),
                         position);
  };
  return scenario;
}

}  // namespace scale_drift_slam::sim::detail
