// courtyard_loop: a camera looking sideways walks one loop around a square courtyard lined with
// facades (like the paper's Keble College sequence), then a little past its start.
//
// Courtyard: 20 m x 20 m (x, y in [-10, 10]), facades 10-13 m high, paved ground. Path: a square
// of half-size 6 m with corners rounded to 3 m radius (4 m from the facades on the straights),
// 42.85 m long, walked counter-clockwise at 1.57 m/s from the middle of the south side, looking
// right (outwards, at the facades), with a walking bob and hand-held wobble; after the loop the
// walk continues 4.3 m (10 %) so that the loop must be closed. 30 s, 900 frames at 30 Hz.

#include <cmath>

#include "scenario_builders.h"
#include "scale_drift_slam/sim/texture_generator.h"

namespace scale_drift_slam::sim::detail {
namespace {

constexpr double kHalfCourt = 10.0;
constexpr double kHalfPath = 6.0;
constexpr double kCornerRadius = 3.0;
constexpr double kDuration = 30.0;

/// Position and heading on the rounded square at arc length s (counter-clockwise from the middle
/// of the south side, heading +x).
void roundedSquare(double s, Eigen::Vector2d& position, Eigen::Vector2d& heading) {
  const double straight = 2.0 * (kHalfPath - kCornerRadius);
  const double arc = 0.5 * M_PI * kCornerRadius;
  const double side = straight + arc;
  const double perimeter = 4.0 * side;
  s = std::fmod(std::fmod(s, perimeter) + perimeter, perimeter);
  // Start at the middle of a straight: shift by half a straight.
  double u = s + straight / 2.0;
  int k = static_cast<int>(u / side) % 4;
  u = std::fmod(u, side);
  Eigen::Vector2d p, d;
  if (u < straight) {
    p = Eigen::Vector2d(-kHalfPath + kCornerRadius + u, -kHalfPath);
    d = Eigen::Vector2d(1, 0);
  } else {
    const double a = (u - straight) / kCornerRadius;  // angle along the corner arc
    const Eigen::Vector2d centre(kHalfPath - kCornerRadius, -kHalfPath + kCornerRadius);
    p = centre + kCornerRadius * Eigen::Vector2d(std::sin(a), -std::cos(a));
    d = Eigen::Vector2d(std::cos(a), std::sin(a));
  }
  const Eigen::Rotation2Dd R(k * 0.5 * M_PI);
  position = R * p;
  heading = R * d;
}

}  // namespace

Scenario makeCourtyardLoop(std::uint32_t seed) {
  Scenario scenario;
  scenario.name = "courtyard_loop";
  scenario.description =
      "sideways camera walking one loop (42.9 m + 4.3 m) around a 20 m x 20 m courtyard of facades";
  scenario.duration = kDuration;
  scenario.rate = 30.0;
  scenario.horizontal_fov_deg = 80.0;
  Scene& scene = scenario.scene;
  const double tpm = 120.0;  // texels per metre on the facades (camera 3-7 m away)
  // Facades: south, east, north, west; each seen from inside the courtyard.
  const Eigen::Vector3d corners[4] = {{-kHalfCourt, -kHalfCourt, 0}, {kHalfCourt, -kHalfCourt, 0},
                                      {kHalfCourt, kHalfCourt, 0}, {-kHalfCourt, kHalfCourt, 0}};
  const float gains[4] = {1.0f, 0.82f, 0.66f, 0.9f};
  const Eigen::Vector3f tints[4] = {{0.8f, 0.95f, 1.2f}, {0.9f, 1.0f, 1.05f}, {0.85f, 1.0f, 1.1f},
                                    {1.0f, 1.0f, 1.0f}};
  cv::RNG rng(seed);
  for (int k = 0; k < 4; ++k) {
    const double height = rng.uniform(10.0, 13.0);
    // Seen from inside the courtyard the facade's left end is the next corner (clockwise).
    const Eigen::Vector3d right = corners[k] - corners[(k + 1) % 4];
    const int index = scene.addQuad(corners[(k + 1) % 4] + Eigen::Vector3d(0, 0, height), right,
                                    Eigen::Vector3d(0, 0, -height),
                                    textures::facade(right.norm(), height, tpm, seed * 16 + k),
                                    gains[k]);
    scene.surface(index).tint = tints[k];
  }
  // The ground: viewed from above, rows along -y.
  const int ground = scene.addQuad(Eigen::Vector3d(-kHalfCourt, kHalfCourt, 0),
                                   Eigen::Vector3d(2 * kHalfCourt, 0, 0),
                                   Eigen::Vector3d(0, -2 * kHalfCourt, 0),
                                   textures::pavedGround(2 * kHalfCourt, 2 * kHalfCourt, 60.0, seed * 16 + 7),
                                   0.95f);
  scene.surface(ground).tint = Eigen::Vector3f(0.95f, 1.0f, 1.0f);

  // The walk: arc length with a step rhythm, height bob, and small head rotations.
  const double perimeter = 4.0 * (2.0 * (kHalfPath - kCornerRadius) + 0.5 * M_PI * kCornerRadius);
  const double speed = 1.1 * perimeter / kDuration;
  const double step_hz = 1.8;
  const Wobble yaw(rng, 0.035, 0.25), pitch(rng, 0.03, 0.3), roll(rng, 0.02, 0.35);
  const Wobble sway(rng, 0.03, 0.4);
  scenario.T_world_cam = [=](double t) {
    const double s = speed * t - speed * 0.08 / (2 * M_PI * step_hz) * std::sin(2 * M_PI * step_hz * t);
    Eigen::Vector2d p, d;
    roundedSquare(s, p, d);
    const Eigen::Vector2d outward(d.y(), -d.x());  // right of the walking direction
    const Eigen::Vector3d position(p.x() + sway(t) * outward.x(), p.y() + sway(t) * outward.y(),
                                   1.6 + 0.025 * std::sin(2 * M_PI * step_hz * t));
    const double a = yaw(t);
    Eigen::Vector3d look(std::cos(a) * outward.x() - std::sin(a) * outward.y(),
                         std::sin(a) * outward.x() + std::cos(a) * outward.y(), 0.0);
    look.z() = std::tan(0.06 + pitch(t));  // slightly upwards, at the facade
    return geometry::SE3(lookRotation(look, Eigen::Vector3d::UnitZ(), roll(t)), position);
  };
  return scenario;
}

}  // namespace scale_drift_slam::sim::detail
