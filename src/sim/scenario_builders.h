#pragma once
// Private to src/sim: the builders of the named scenarios (sim/scenario.h) and their helpers.

#include <cstdint>

#include <opencv2/core.hpp>

#include "scale_drift_slam/sim/scenario.h"

namespace scale_drift_slam::sim::detail {

Scenario makeCourtyardLoop(std::uint32_t seed);
Scenario makeOfficeOrbit(std::uint32_t seed);
Scenario makeCorridorStraight(std::uint32_t seed);
Scenario makeSphereFlyover(std::uint32_t seed);
Scenario makeDesk(std::uint32_t seed);
Scenario makeFacadeGrid(std::uint32_t seed);
Scenario makeOfficePan(std::uint32_t seed);
Scenario makeSlider(std::uint32_t seed);
Scenario makeCityBlock(std::uint32_t seed, const ScenarioOptions& options);
Scenario makeCityLoop(std::uint32_t seed, const ScenarioOptions& options);
Scenario makeCityTour(std::uint32_t seed, const ScenarioOptions& options);

/// The furnished 6 m x 5 m x 2.7 m room of office_orbit (walls, floor, ceiling, desk with a
/// monitor, cabinets, shelves, boxes); returns the desk's base centre.
Eigen::Vector3d addOfficeRoom(Scene& scene, std::uint32_t seed);

/// An axis-aligned box (rotated by `yaw` about z) standing on z = base.z(): four textured sides
/// and a textured top, all visible from outside only.
void addBox(Scene& scene, const Eigen::Vector3d& base_centre, const Eigen::Vector3d& size,
            double yaw, const cv::Mat& side, const cv::Mat& top, float gain = 1.0f);

/// A smooth pseudo-random wobble: a sum of three sinusoids with seed-dependent phases and
/// frequencies around `frequency` (Hz), amplitude about `amplitude`.
class Wobble {
 public:
  Wobble(cv::RNG& rng, double amplitude, double frequency);
  double operator()(double t) const;

 private:
  double amplitude_[3], frequency_[3], phase_[3];
};

}  // namespace scale_drift_slam::sim::detail
