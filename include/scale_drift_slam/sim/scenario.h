#pragma once
// The named synthetic sequences (stable names; tests, tools and checks rely on them): a scene, a
// smooth camera trajectory with the exact pose at any time, and the default camera. Scenes are in
// metres, world z up; camera frames follow the optical convention (x right, y down, z forward).

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/sim/scene.h"

namespace scale_drift_slam::sim {

/// An object moving on its own (a car in traffic): a box on the ground, where it is at one time.
struct MovingObject {
  bool present = false;      ///< Out of the world at this time (not yet come or gone).
  Eigen::Vector2d position;  ///< Centre of its footprint (world x-y, metres).
  Eigen::Vector2d heading;   ///< Unit direction it faces (its length axis).
  Eigen::Vector3d size;      ///< Length (along heading), width, height (metres).
  int first_surface = -1;    ///< Its surfaces in Scenario::scene: a box, 5 from here.
};

/// What a scenario holds besides its fixed world.
struct ScenarioOptions {
  /// Moving cars in the streets (city_* scenes only): Scenario::animate and moving_objects.
  bool traffic = false;
  /// The traffic's seed (unset: the scenario's).
  std::optional<std::uint32_t> traffic_seed;
  /// The camera's drive (the motion) from this seed (unset: the scenario's); the traffic keeps
  /// clear of that drive.
  std::optional<std::uint32_t> motion_seed;
  /// The route driven this many times, in the same city (city_loop only; the benchmark's long
  /// run, scripts/bench city).
  int laps = 1;
  /// The car's yaw rate in the turns, degrees per second (city_* scenes only; unset: ~29, as a
  /// car turns in town). The turn speed is this rate times the turn's radius (9-13 m): 50 deg/s
  /// takes the corners at 8-11 m/s, 5 degrees and ~65 px of image motion per frame at 10 Hz.
  std::optional<double> turn_rate_deg_s;
};

/// A scene and the camera's path through it. Built by makeScenario(); read-only afterwards except
/// through `animate`.
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
  /// With moving objects: moves their surfaces in `scene` to where they are at time t (hidden
  /// when not present); empty for a still world. Call before rendering each time.
  std::function<void(double t, Scene& scene)> animate;
  /// With moving objects: all of them at time t (empty function for a still world).
  std::function<std::vector<MovingObject>(double t)> moving_objects;
};

/// courtyard_loop, office_orbit, corridor_straight, sphere_flyover, desk, office_pan, city_block,
/// city_loop, facade_grid.
std::vector<std::string> scenarioNames();
/// Builds a scenario; textures (and the small hand-held wobble) depend on the seed only.
/// Throws std::invalid_argument naming the known scenes for an unknown name, for traffic in a
/// scene without streets, and for laps other than 1 outside city_loop (ScenarioOptions).
Scenario makeScenario(const std::string& name, std::uint32_t seed,
                      const ScenarioOptions& options = {});

/// The default image size (width, height) of a named scene, known without building it: 1241 x 376
/// (KITTI-like) for the city_* driving scenes, 640 x 480 for the others.
Eigen::Vector2i defaultImageSize(const std::string& name);

/// The camera orientation (camera -> world) looking along `forward` with the image's up as close
/// to `up` as possible, then rolled by `roll` radians about the viewing direction.
Eigen::Matrix3d lookRotation(const Eigen::Vector3d& forward, const Eigen::Vector3d& up,
                             double roll = 0.0);

}  // namespace scale_drift_slam::sim
