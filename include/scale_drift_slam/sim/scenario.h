#pragma once
// The named synthetic sequences (stable names; tests, tools and checks rely on them): a scene, a
// smooth camera trajectory with the exact pose at any time, and the default camera. Scenes are in
// metres, world z up; camera frames follow the optical convention (x right, y down, z forward).

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/sim/scene.h"

namespace scale_drift_slam::sim {

/// A scene and the camera's path through it. Built by makeScenario(); read-only afterwards.
struct Scenario {
  std::string name;
  std::string description;
  Scene scene;
  double duration = 0.0;             ///< Seconds covered by the trajectory.
  double rate = 30.0;                ///< Default frame rate (Hz).
  double horizontal_fov_deg = 80.0;  ///< Default horizontal field of view of the camera.
  std::string distortion = "none";   ///< Default lens (SequenceParams::distortion).
  /// The camera pose in the world (camera -> world) at time t in [0, duration].
  std::function<geometry::SE3(double t)> T_world_cam;
};

/// courtyard_loop, office_orbit, corridor_straight, sphere_flyover, desk, office_pan, city_block,
/// city_loop, facade_grid.
std::vector<std::string> scenarioNames();
/// Builds a scenario; textures (and the small hand-held wobble) depend on the seed only.
/// Throws std::invalid_argument naming the known scenes for an unknown name. `laps` (in [1, 100];
/// city_loop only, else std::invalid_argument): the route driven that many times, in the same
/// city (the benchmark's long run, scripts/bench city).
Scenario makeScenario(const std::string& name, std::uint32_t seed, int laps = 1);

/// The default image size (width, height) of a named scene, known without building it: 1241 x 376
/// (KITTI-like) for the city_* driving scenes, 640 x 480 for the others.
Eigen::Vector2i defaultImageSize(const std::string& name);

/// The camera orientation (camera -> world) looking along `forward` with the image's up as close
/// to `up` as possible, then rolled by `roll` radians about the viewing direction.
Eigen::Matrix3d lookRotation(const Eigen::Vector3d& forward, const Eigen::Vector3d& up,
                             double roll = 0.0);

}  // namespace scale_drift_slam::sim
