#pragma once
// The worlds of the paper's simulations (doc/algorithm.md, "The paper's evidence"): 3D points
// and a true camera trajectory, observed through a pinhole camera with Gaussian pixel noise.
// Data association is given: every measurement carries the id of the point it images.
//   - circle: 720 poses on a circle of radius 10 m looking outwards; 5000 points on a ring of
//     radius 11 m, height in [-1, 1]; 320x240, f = 195, principal point (162, 125).
//   - sphere: 15000 points on a sphere of radius 10 m; an aircraft flying great circles at
//     radius 12 m with a downward camera, the orbit plane turning by 180/loops degrees per
//     revolution, so that every orbit crosses both poles and revisits what earlier ones mapped.
// Plain data plus pure functions; no global state.

#include <random>
#include <vector>

#include <Eigen/Core>

#include "scale_drift_slam/geometry/se3.h"

namespace scale_drift_slam::sim {

struct PinholeCamera {
  int width = 320;
  int height = 240;
  double focal_length = 195.0;  ///< fx = fy, pixels.
  Eigen::Vector2d principal_point{162.0, 125.0};
  double border_px = 2.0;  ///< Measurements closer to the image edge are not made.
};

struct SimulatedWorld {
  PinholeCamera camera;
  std::vector<Eigen::Vector3d> points;
  /// Outward surface normals (empty: no occlusion). A point is seen only from the side its
  /// normal points to (the sphere hides its far side).
  std::vector<Eigen::Vector3d> normals;
  std::vector<geometry::SE3> T_cam_world;  ///< The true pose of every frame.
  std::vector<double> timestamps;
};

/// A measurement of point `point` in normalised coordinates (pixel noise already added).
struct Measurement {
  int point = 0;
  Eigen::Vector2d xy = Eigen::Vector2d::Zero();
};

struct CircleWorldParams {
  int num_poses = 720;
  int num_points = 5000;
  double camera_radius = 10.0;
  double ring_radius = 11.0;
  double ring_half_height = 1.0;
  /// Fraction of the full circle the poses cover; 1 = the camera returns to its start.
  double arc_fraction = 1.0;
  void validate() const;  ///< Throws std::invalid_argument.
};

struct SphereWorldParams {
  int num_points = 15000;
  double sphere_radius = 10.0;
  double flight_radius = 12.0;
  int revolutions = 6;  ///< Each after the first revisits both poles: 2 r - 2 loops.
  int poses_per_revolution = 500;
  void validate() const;  ///< Throws std::invalid_argument.
};

SimulatedWorld makeCircleWorld(const CircleWorldParams& params, std::mt19937& rng);
SimulatedWorld makeSphereWorld(const SphereWorldParams& params, std::mt19937& rng);

/// Every point that projects into the image of frame `frame` (in front, inside the border), with
/// Gaussian noise of `noise_px` pixels per coordinate. Throws std::out_of_range for a bad frame.
std::vector<Measurement> measureFrame(const SimulatedWorld& world, std::size_t frame,
                                      double noise_px, std::mt19937& rng);

}  // namespace scale_drift_slam::sim
