// desk: a hand-held camera over a desk, the case of a mostly planar scene under small motion
// (TUM RGB-D fr1/desk-like: 640x480, 30 Hz, fx ~517, its strong radial distortion). The desk top
// (2.0 m x 1.5 m, z = 0, x in [-1, 1], y in [-0.6, 0.9]) is one textured plane: wood, papers,
// notebooks, sticky notes, a keyboard, a mouse pad. On it stand a monitor on a foot, a stack of
// books, a mug (a 16-sided cylinder) and a small box: 16-27 % of the image is off the plane.
// A wall stands behind the desk and a floor 0.75 m below it, seen only when the camera looks up.
// The camera, 0.6 m above the desk and looking down ~47 degrees, is held still for the first
// kStillSeconds (10 frames), then moves like a hand: it speeds up over 0.15 s to ~12 cm/s,
// sweeps sideways and back and forth by a few centimetres to 0.2 m, turns slowly (~5-10 deg/s)
// and shakes (a few mm at 1-2 Hz). 10 s, 300 frames at 30 Hz.

#include <cmath>

#include "scale_drift_slam/sim/texture_generator.h"
#include "scenario_builders.h"

namespace scale_drift_slam::sim::detail {
namespace {

constexpr double kStillSeconds = 10.0 / 30.0;  ///< The camera is still for the first 10 frames.
constexpr double kRampSeconds = 0.15;          ///< A hand gets going within a few frames.

/// Motion time: 0 while still, then a smooth start (its rate rises from 0 to 1 over
/// kRampSeconds with 3u^2 - 2u^3), then real time: the pose is continuous with no velocity jump.
double motionTime(double t) {
  const double s = t - kStillSeconds;
  if (s <= 0.0) return 0.0;
  if (s >= kRampSeconds) return s - 0.5 * kRampSeconds;
  const double u = s / kRampSeconds;
  return kRampSeconds * (u * u * u - 0.5 * u * u * u * u);
}

/// A mug: an upright `facets`-sided cylinder with an outward texture and a dark top.
void addCylinder(Scene& scene, const Eigen::Vector3d& base_centre, double radius, double height,
                 const cv::Mat& side, int facets) {
  const int texture = scene.addTexture(side);
  const int top = scene.addTexture(cv::Mat(8, 8, CV_8U, cv::Scalar(35)));  // coffee
  const double w = scene.texture(texture).width(), h = scene.texture(texture).height();
  const Eigen::Vector3d up(0, 0, height);
  auto rim = [&](int k) -> Eigen::Vector3d {
    const double a = 2.0 * M_PI * k / facets;
    return base_centre + radius * Eigen::Vector3d(std::cos(a), std::sin(a), 0.0);
  };
  for (int k = 0; k < facets; ++k) {
    const Eigen::Vector3d p0 = rim(k), p1 = rim(k + 1);
    const double u0 = w * k / facets, u1 = w * (k + 1) / facets;
    // Counter-clockwise seen from outside: (p0 + up, p1 + up, p0) faces outwards.
    scene.surface(scene.addTriangle(p0 + up, p1 + up, p0, {u0, 0}, {u1, 0}, {u0, h}, texture))
        .double_sided = false;
    scene.surface(scene.addTriangle(p1, p0, p1 + up, {u1, h}, {u0, h}, {u1, 0}, texture))
        .double_sided = false;
    scene
        .surface(scene.addTriangle(base_centre + up, p1 + up, p0 + up, {4, 8}, {8, 0}, {0, 0}, top))
        .double_sided = false;
  }
}

void addDeskAndRoom(Scene& scene, std::uint32_t base) {
  scene.background().below = scene.background().zenith = scene.background().horizon = 40.0f;
  const double tpm = 800.0;  // ~1 texel per pixel at 0.65 m with fx 517
  scene.addQuad(Eigen::Vector3d(-1.0, 0.9, 0.0), Eigen::Vector3d(2.0, 0, 0),
                Eigen::Vector3d(0, -1.5, 0), textures::deskTop(2.0, 1.5, tpm, base));
  scene.addQuad(Eigen::Vector3d(-2.0, 0.9, 1.5), Eigen::Vector3d(4.0, 0, 0),
                Eigen::Vector3d(0, 0, -2.25),
                textures::interiorWall(4.0, 2.25, 150, base + 1, false), 0.9f);
  scene.addQuad(Eigen::Vector3d(-2.0, 0.9, -0.75), Eigen::Vector3d(4.0, 0, 0),
                Eigen::Vector3d(0, -2.7, 0),
                textures::floorMaterial("carpet", 4.0, 2.7, 120, base + 2), 0.7f);
  // The monitor: a foot, a neck and the screen facing the camera (-y).
  const Eigen::Vector3d monitor(0.05, 0.35, 0.0);
  addBox(scene, monitor, {0.22, 0.16, 0.02}, 0.0,
         textures::furniture("cabinet", 0.22, 0.02, 400, base + 3),
         textures::floorMaterial("carpet", 0.22, 0.16, 400, base + 4), 0.5f);
  addBox(scene, monitor + Eigen::Vector3d(0, 0.02, 0.02), {0.05, 0.03, 0.1}, 0.0,
         textures::floorMaterial("carpet", 0.05, 0.1, 400, base + 5),
         textures::floorMaterial("carpet", 0.05, 0.03, 400, base + 6), 0.5f);
  addBox(scene, monitor + Eigen::Vector3d(0, 0, 0.1), {0.56, 0.04, 0.34}, 0.0,
         textures::furniture("screen", 0.56, 0.34, 800, base + 7),
         textures::floorMaterial("carpet", 0.56, 0.04, 400, base + 8), 0.9f);
  // Books, a small box and a mug.
  cv::RNG book_rng(base + 10);
  addBox(scene, {-0.4, 0.08, 0.0}, {0.24, 0.17, 0.09}, 0.35,
         textures::furniture("books", 0.24, 0.09, 800, base + 9),
         textures::poster(cv::Size(190, 135), book_rng));
  addBox(scene, {0.45, 0.12, 0.0}, {0.12, 0.1, 0.16}, -0.3,
         textures::furniture("cabinet", 0.12, 0.16, 800, base + 11),
         textures::poster(cv::Size(96, 80), book_rng), 0.8f);
  cv::RNG mug_rng(base + 13);
  addCylinder(scene, {0.28, -0.08, 0.0}, 0.04, 0.1, textures::poster(cv::Size(200, 80), mug_rng),
              16);
}

}  // namespace

Scenario makeDesk(std::uint32_t seed) {
  Scenario scenario;
  scenario.name = "desk";
  scenario.description =
      "hand-held camera over a mostly planar desk, still for 10 frames, then small motion; "
      "TUM fr1 lens";
  scenario.duration = 10.0;
  scenario.rate = 30.0;
  scenario.horizontal_fov_deg = 2.0 * std::atan(320.0 / 517.3) * 180.0 / M_PI;  // fx 517.3
  scenario.distortion = "tum_fr1";
  addDeskAndRoom(scenario.scene, seed * 64);

  cv::RNG rng(seed + 2000);
  const Wobble shake_x(rng, 0.003, 1.5), shake_y(rng, 0.003, 1.8), shake_z(rng, 0.002, 1.3);
  const Wobble look_x(rng, 0.06, 0.2), look_y(rng, 0.05, 0.25), roll(rng, 0.03, 0.3);
  const double sweep_phase = rng.uniform(0.0, 2.0 * M_PI);
  const Eigen::Vector3d start(0.0, -0.55, 0.6), target(0.0, 0.0, 0.0);
  scenario.T_world_cam = [=](double t) {
    const double m = motionTime(t);
    // Offsets from the still pose: zero at m = 0, with a velocity of ~12 cm/s there.
    auto sweep = [&](double amplitude, double period, double phase) {
      return amplitude * (std::sin(2 * M_PI * m / period + phase) - std::sin(phase));
    };
    auto wobble = [m](const Wobble& w) { return w(m) - w(0.0); };
    const Eigen::Vector3d position =
        start +
        Eigen::Vector3d(sweep(0.18, 9.0, 0.0), sweep(0.06, 7.0, sweep_phase),
                        sweep(0.04, 6.0, 0.0)) +
        Eigen::Vector3d(wobble(shake_x), wobble(shake_y), wobble(shake_z));
    const Eigen::Vector3d look =
        target + Eigen::Vector3d(wobble(look_x), wobble(look_y), 0.0) +
        Eigen::Vector3d(0.5 * (position.x() - start.x()), 0.0, 0.0);  // follows the sweep halfway
    return geometry::SE3(lookRotation(look - position, Eigen::Vector3d::UnitZ(), wobble(roll)),
                         position);
  };
  return scenario;
}

}  // namespace scale_drift_slam::sim::detail
