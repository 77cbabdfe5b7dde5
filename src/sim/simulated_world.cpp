#include "scale_drift_slam/sim/simulated_world.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace scale_drift_slam::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

/// The pose T_cam_world of a camera at `centre` whose optical axis (z) is `forward` and whose
/// image x axis is `right` (orthogonalised against forward).
geometry::SE3 lookAlong(const Eigen::Vector3d& centre, const Eigen::Vector3d& forward,
                        const Eigen::Vector3d& right) {
  const Eigen::Vector3d z = forward.normalized();
  const Eigen::Vector3d x = (right - right.dot(z) * z).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d R_world_cam;
  R_world_cam << x, y, z;
  const Eigen::Matrix3d R_cam_world = R_world_cam.transpose();
  return geometry::SE3(R_cam_world, -(R_cam_world * centre));
}

}  // namespace

void CircleWorldParams::validate() const {
  auto fail = [](const std::string& what) { throw std::invalid_argument("circle world: " + what); };
  if (num_poses < 3) fail("num_poses must be >= 3");
  if (num_points < 1) fail("num_points must be >= 1");
  if (!(camera_radius > 0.0)) fail("camera_radius must be > 0");
  if (!(ring_radius > camera_radius)) fail("ring_radius must exceed camera_radius");
  if (!(ring_half_height >= 0.0)) fail("ring_half_height must be >= 0");
  if (!(arc_fraction > 0.0 && arc_fraction <= 1.0)) fail("arc_fraction must be in (0, 1]");
}

void SphereWorldParams::validate() const {
  auto fail = [](const std::string& what) { throw std::invalid_argument("sphere world: " + what); };
  if (num_points < 1) fail("num_points must be >= 1");
  if (!(sphere_radius > 0.0)) fail("sphere_radius must be > 0");
  if (!(flight_radius > sphere_radius)) fail("flight_radius must exceed sphere_radius");
  if (revolutions < 1) fail("revolutions must be >= 1");
  if (poses_per_revolution < 8) fail("poses_per_revolution must be >= 8");
}

SimulatedWorld makeCircleWorld(const CircleWorldParams& params, std::mt19937& rng) {
  params.validate();
  SimulatedWorld world;
  std::uniform_real_distribution<double> angle(0.0, 2.0 * kPi);
  std::uniform_real_distribution<double> height(-params.ring_half_height, params.ring_half_height);
  for (int j = 0; j < params.num_points; ++j) {
    const double a = angle(rng);
    world.points.emplace_back(params.ring_radius * std::cos(a), params.ring_radius * std::sin(a),
                              height(rng));
  }
  // Pose i at angle 2 pi i / num_poses (a full circle of 720 poses ends half a degree before the
  // start); the camera looks outwards, its image x axis along the direction of travel.
  const double step = 2.0 * kPi * params.arc_fraction / params.num_poses;
  for (int i = 0; i < params.num_poses; ++i) {
    const double a = step * i;
    const Eigen::Vector3d radial(std::cos(a), std::sin(a), 0.0);
    const Eigen::Vector3d tangent(-std::sin(a), std::cos(a), 0.0);
    world.T_cam_world.push_back(lookAlong(params.camera_radius * radial, radial, tangent));
    world.timestamps.push_back(i / 30.0);
  }
  return world;
}

SimulatedWorld makeSphereWorld(const SphereWorldParams& params, std::mt19937& rng) {
  params.validate();
  SimulatedWorld world;
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int j = 0; j < params.num_points; ++j) {
    const Eigen::Vector3d d(normal(rng), normal(rng), normal(rng));
    world.points.push_back(params.sphere_radius * d.normalized());
    world.normals.push_back(d.normalized());
  }
  // theta runs along the orbit; the orbit plane (spanned by e(phi) = (-sin phi, cos phi, 0) and
  // z) turns with phi = theta / (2 revolutions): after each revolution by 180 / revolutions
  // degrees, and every orbit crosses both poles.
  const int n = params.revolutions * params.poses_per_revolution;
  for (int i = 0; i < n; ++i) {
    const double theta = 2.0 * kPi * i / params.poses_per_revolution;
    auto position = [&](double t) {
      const double phi = t / (2.0 * params.revolutions);
      const Eigen::Vector3d e(-std::sin(phi), std::cos(phi), 0.0);
      return Eigen::Vector3d(params.flight_radius *
                             (std::cos(t) * e + std::sin(t) * Eigen::Vector3d::UnitZ()));
    };
    const Eigen::Vector3d centre = position(theta);
    const Eigen::Vector3d velocity = position(theta + 1e-4) - position(theta - 1e-4);
    world.T_cam_world.push_back(lookAlong(centre, -centre, velocity));
    world.timestamps.push_back(i / 30.0);
  }
  return world;
}

std::vector<Measurement> measureFrame(const SimulatedWorld& world, std::size_t frame,
                                      double noise_px, std::mt19937& rng) {
  if (frame >= world.T_cam_world.size()) {
    throw std::out_of_range("frame " + std::to_string(frame) + " is not in the simulation");
  }
  const PinholeCamera& cam = world.camera;
  const geometry::SE3& T = world.T_cam_world[frame];
  const Eigen::Matrix3d R = T.rotationMatrix();
  const Eigen::Vector3d t = T.translation();
  const Eigen::Vector3d centre = T.inverseTranslation();
  const bool occlusion = world.normals.size() == world.points.size();
  std::normal_distribution<double> noise(0.0, noise_px);
  std::vector<Measurement> measurements;
  const double lo_x = cam.border_px, hi_x = cam.width - cam.border_px;
  const double lo_y = cam.border_px, hi_y = cam.height - cam.border_px;
  for (std::size_t j = 0; j < world.points.size(); ++j) {
    const Eigen::Vector3d y = R * world.points[j] + t;
    if (y.z() < 0.05) continue;
    if (occlusion && world.normals[j].dot(centre - world.points[j]) <= 0.0) continue;
    const Eigen::Vector2d pixel = cam.focal_length * y.head<2>() / y.z() + cam.principal_point;
    if (pixel.x() < lo_x || pixel.x() > hi_x || pixel.y() < lo_y || pixel.y() > hi_y) continue;
    const Eigen::Vector2d noisy = pixel + Eigen::Vector2d(noise(rng), noise(rng));
    measurements.push_back({static_cast<int>(j), (noisy - cam.principal_point) / cam.focal_length});
  }
  return measurements;
}

}  // namespace scale_drift_slam::sim
