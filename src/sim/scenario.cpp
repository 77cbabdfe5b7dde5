#include "scale_drift_slam/sim/scenario.h"

#include <cmath>
#include <stdexcept>

#include "scenario_builders.h"

namespace scale_drift_slam::sim {

std::vector<std::string> scenarioNames() {
  return {"courtyard_loop", "office_orbit", "corridor_straight", "sphere_flyover", "desk",
          "office_pan",     "city_block",   "city_loop",         "city_tour",      "facade_grid",
          "slider"};
}

Scenario makeScenario(const std::string& name, std::uint32_t seed, const ScenarioOptions& options) {
  if (options.laps < 1 || options.laps > 100)
    throw std::invalid_argument("laps must be in [1, 100]");
  if (options.laps != 1 && name != "city_loop") {
    throw std::invalid_argument("only city_loop can be driven more than once (laps), not '" + name +
                                "'");
  }
  if (options.turn_rate_deg_s &&
      !(*options.turn_rate_deg_s >= 5.0 && *options.turn_rate_deg_s <= 120.0)) {
    throw std::invalid_argument("turn rate must be in [5, 120] deg/s");
  }
  if (options.turn_rate_deg_s && name.rfind("city_", 0) != 0) {
    throw std::invalid_argument("a turn rate needs a drive: only the city_* scenes have it, not '" +
                                name + "'");
  }
  if (name == "city_block") return detail::makeCityBlock(seed, options);
  if (name == "city_loop") return detail::makeCityLoop(seed, options);
  if (name == "city_tour") return detail::makeCityTour(seed, options);
  if (options.traffic) {
    throw std::invalid_argument("traffic needs streets: only the city_* scenes have it, not '" +
                                name + "'");
  }
  if (name == "courtyard_loop") return detail::makeCourtyardLoop(seed);
  if (name == "office_orbit") return detail::makeOfficeOrbit(seed);
  if (name == "corridor_straight") return detail::makeCorridorStraight(seed);
  if (name == "sphere_flyover") return detail::makeSphereFlyover(seed);
  if (name == "desk") return detail::makeDesk(seed);
  if (name == "office_pan") return detail::makeOfficePan(seed);
  if (name == "facade_grid") return detail::makeFacadeGrid(seed);
  if (name == "slider") return detail::makeSlider(seed);
  std::string known;
  for (const std::string& n : scenarioNames())
    known += (known.empty() ? "" : ", ") + n;
  throw std::invalid_argument("unknown scene '" + name + "' (known: " + known + ")");
}

Eigen::Vector2i defaultImageSize(const std::string& name) {
  // The driving scenes have a KITTI-like camera; the others a VGA one.
  if (name.rfind("city_", 0) == 0) return {1241, 376};
  if (name == "slider") return {240, 180};  // DAVIS240C
  return {640, 480};
}

Eigen::Matrix3d lookRotation(const Eigen::Vector3d& forward, const Eigen::Vector3d& up,
                             double roll) {
  const Eigen::Vector3d z = forward.normalized();
  Eigen::Vector3d x = z.cross(up);
  if (x.norm() < 1e-9) x = z.cross(Eigen::Vector3d::UnitX());
  x.normalize();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d R;
  R << x, y, z;
  return R * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

namespace detail {

void addBox(Scene& scene, const Eigen::Vector3d& base_centre, const Eigen::Vector3d& size,
            double yaw, const cv::Mat& side, const cv::Mat& top, float gain) {
  const Eigen::Matrix3d R = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d ex = R.col(0) * size.x(), ey = R.col(1) * size.y();
  const Eigen::Vector3d ez = Eigen::Vector3d::UnitZ() * size.z();
  const Eigen::Vector3d corner = base_centre - ex / 2 - ey / 2;  // bottom, -x -y
  const int side_texture = scene.addTexture(side);
  // Sides, counter-clockwise seen from above, each with edge1 x edge2 pointing outwards.
  const Eigen::Vector3d corners[4] = {corner, corner + ex, corner + ex + ey, corner + ey};
  const Eigen::Vector3d edges[4] = {ex, ey, -ex, -ey};
  const float shade[4] = {1.0f, 0.85f, 0.7f, 0.9f};
  for (int k = 0; k < 4; ++k) {
    const int index = scene.addQuad(corners[k] + ez, edges[k], -ez, side_texture, gain * shade[k]);
    scene.surface(index).double_sided = false;
  }
  const int index = scene.addQuad(corner + ez + ey, ex, -ey, top, gain);
  scene.surface(index).double_sided = false;
}

Wobble::Wobble(cv::RNG& rng, double amplitude, double frequency) {
  for (int k = 0; k < 3; ++k) {
    amplitude_[k] = amplitude * rng.uniform(0.3, 0.7);
    frequency_[k] = frequency * rng.uniform(0.5, 1.6);
    phase_[k] = rng.uniform(0.0, 2.0 * M_PI);
  }
}

double Wobble::operator()(double t) const {
  double sum = 0.0;
  for (int k = 0; k < 3; ++k)
    sum += amplitude_[k] * std::sin(2.0 * M_PI * frequency_[k] * t + phase_[k]);
  return sum;
}

}  // namespace detail
}  // namespace scale_drift_slam::sim
