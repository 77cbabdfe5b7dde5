#pragma once
// Private to src/sim: moving cars in the streets of the driving world (render_sequence --traffic).
//
// Each car drives a route of its own (city_route.h: straights, arcs of 9-13 m, braking for the
// turns) in the right-hand lane of the street centre lines it follows: oncoming cars drive the
// camera's route backwards in the other lane, crossing cars go straight over the junctions the
// camera passes, merging cars come out of a side street (or the street ahead) and turn into the
// camera's street ahead of it. A car is in the world from a moment where the camera cannot see it
// (behind the camera or behind a block's buildings) to the next such
// moment after it came closest to the camera, so cars never pop up in view. Candidates whose
// footprint (with a margin) would touch the camera's car or a car already placed at any time
// both are in the world are dropped. Everything follows from the seed.

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "city_world.h"
#include "scale_drift_slam/sim/scenario.h"

namespace scale_drift_slam::sim::detail {

/// The camera's car: its footprint's centre is this far behind the camera (metres), its size.
constexpr double kEgoBehindCamera = 1.2;
constexpr double kEgoLength = 4.5, kEgoWidth = 1.8;

/// The camera's car at time t (from the camera pose: position under the camera, heading along
/// the optical axis), as a moving object.
MovingObject egoCar(const Scenario& scenario, double t);

/// Whether two footprints come closer than `margin` (separating axes of the two rectangles).
bool footprintsOverlap(const MovingObject& a, const MovingObject& b, double margin);

/// Adds traffic to a city scenario (its scene, drive and duration built): car boxes in the scene
/// and Scenario::animate / moving_objects. `streets`: the centre lines the camera drives.
void addTraffic(Scenario& scenario, const CityGrid& grid,
                const std::vector<Eigen::Vector2d>& streets, std::uint32_t seed);

}  // namespace scale_drift_slam::sim::detail
