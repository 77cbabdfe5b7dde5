// office_pan: a hand-held camera panning fast in the office_orbit room, as a person turning on the
// spot with the camera held 0.35 m in front of them (so the pan carries a baseline). Still-ish
// for 2 s (hand shake and a slow sway: the map starts), then back-and-forth pans of 120 degrees
// at up to 150 deg/s (5 deg per frame at 30 Hz), smooth at each turn-around. 10 s, 300 frames.

#include <cmath>

#include "scenario_builders.h"

namespace scale_drift_slam::sim::detail {

namespace {

constexpr double kStill = 2.0;                      ///< Seconds before the pans start.
constexpr double kPanAmplitude = M_PI / 3.0;        ///< Half of the 120 degree swing.
constexpr double kPeakRate = 150.0 * M_PI / 180.0;  ///< rad/s at the middle of a pan.

/// Heading of the person (radians about z): 90 degrees (facing the desk) while still, then
/// 90 + A (1 - cos(w t)) with A w = the peak rate: zero rate at each turn-around.
double heading(double t) {
  if (t < kStill) return 0.5 * M_PI;
  const double w = kPeakRate / kPanAmplitude;
  return 0.5 * M_PI + kPanAmplitude * (1.0 - std::cos(w * (t - kStill)));
}

}  // namespace

Scenario makeOfficePan(std::uint32_t seed) {
  Scenario scenario;
  scenario.name = "office_pan";
  scenario.description = "hand-held camera panning 120 degrees back and forth at up to 150 deg/s";
  scenario.duration = 10.0;
  scenario.rate = 30.0;
  scenario.horizontal_fov_deg = 65.0;
  addOfficeRoom(scenario.scene, seed);
  cv::RNG rng(seed + 2000);
  const Wobble shake_x(rng, 0.006, 1.5), shake_y(rng, 0.006, 1.7), shake_z(rng, 0.005, 1.3);
  const Wobble sway(rng, 0.04, 0.3), look_up(rng, 0.04, 0.4), roll(rng, 0.03, 0.3);
  const Eigen::Vector3d pivot(0.2, -1.0, 1.45);  // where the person stands, at eye height
  scenario.T_world_cam = [=](double t) {
    const double psi = heading(t);
    const Eigen::Vector3d forward(std::cos(psi), std::sin(psi), 0.0);
    const Eigen::Vector3d side(-forward.y(), forward.x(), 0.0);
    const Eigen::Vector3d position = pivot + 0.35 * forward + sway(t) * side +
                                     Eigen::Vector3d(shake_x(t), shake_y(t), shake_z(t));
    const Eigen::Vector3d look = forward + Eigen::Vector3d(0, 0, -0.25 + look_up(t));
    return geometry::SE3(lookRotation(look, Eigen::Vector3d::UnitZ(), roll(t)), position);
  };
  return scenario;
}

}  // namespace scale_drift_slam::sim::detail
