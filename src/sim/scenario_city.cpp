// city_block and city_loop: a forward-looking camera on a car driving through a city of blocks
// (city_world.h), KITTI-like: 1.65 m above the road, 1241 x 376, fx = fy = 718.9, 10 Hz. The car
// keeps to the right lane (1.75 m right of the centre line), turns right at the crossings on arcs
// of 9-13 m radius at about 29 deg/s (5-6.5 m/s), cruises at 9.5-13 m/s between them with
// 1.6 m/s^2 braking and acceleration, and shakes a little (engine and road: height, pitch, roll).
//
// city_block: one loop clockwise round a 110 m x 75 m block (~320 m), started in the middle of
// the west street, then on 37 m (11 % of the loop) past the start so that the loop must be closed.
// city_loop: a 330 m x 160 m loop round six blocks, then a second, smaller loop that re-drives
// the first loop's west and south streets in the same direction (~1.6 km in all); with laps > 1
// the whole route again from its south-west corner, as often (scripts/bench city).
// city_tour: ~5.6 km through 40 blocks (8 x 5) that it mostly sees once: north up the west edge,
// then east and west along five streets in turn (a serpentine, left and right turns), back west
// along the south edge and north again through the start (one large loop), for the city-scale
// benchmark (1000+ keyframes of new streets).

#include <cmath>

#include "city_route.h"
#include "city_traffic.h"
#include "city_world.h"
#include "scenario_builders.h"

namespace scale_drift_slam::sim::detail {
namespace {

constexpr double kCameraHeight = 1.65;
constexpr double kLaneOffset = 1.75;
// KITTI's fx = 718.9 at 1241 px wide: the horizontal field of view that gives it.
const double kKittiFovDeg = 2.0 * std::atan(1241.0 / 2.0 / 718.9) * 180.0 / M_PI;

/// Fills in the drive: the camera's pose along the lane of `streets` (centre lines).
void addDrive(Scenario& scenario, const std::vector<Eigen::Vector2d>& streets, std::uint32_t seed,
              const ScenarioOptions& options) {
  DriveParams drive;
  if (options.turn_rate_deg_s) drive.turn_yaw_rate = *options.turn_rate_deg_s * M_PI / 180.0;
  const auto route = std::make_shared<CityRoute>(offsetRight(streets, kLaneOffset), drive, seed);
  scenario.duration = route->duration();
  scenario.rate = 10.0;
  scenario.horizontal_fov_deg = kKittiFovDeg;
  cv::RNG rng(seed * 31u + 7u);
  // Vibration: engine and road roughness (a few Hz, mm and tenths of a degree) and slow lane
  // keeping (a few cm); the body leans out of the turns.
  const Wobble bounce(rng, 0.006, 2.5), pitch(rng, 0.003, 1.8), roll(rng, 0.002, 2.2);
  const Wobble yaw(rng, 0.002, 0.4), sway(rng, 0.05, 0.08);
  scenario.T_world_cam = [=](double t) {
    const CityRoute::State state = route->atTime(t);
    const Eigen::Vector2d right(state.heading.y(), -state.heading.x());
    const Eigen::Vector2d p = state.position + sway(t) * right;
    const Eigen::Vector3d position(p.x(), p.y(), kCameraHeight + bounce(t));
    const double a = yaw(t);
    const Eigen::Vector3d look(std::cos(a) * state.heading.x() - std::sin(a) * state.heading.y(),
                               std::sin(a) * state.heading.x() + std::cos(a) * state.heading.y(),
                               std::tan(pitch(t)));
    const double lean = 0.004 * state.speed * state.speed * state.curvature;  // rad per m/s^2 / 2.5
    return geometry::SE3(lookRotation(look, Eigen::Vector3d::UnitZ(), roll(t) + lean), position);
  };
  scenario.description += " (" + std::to_string(static_cast<int>(route->length())) + " m, " +
                          std::to_string(static_cast<int>(route->duration())) + " s)";
}

/// Streets at x = 0 .. blocks_x pitch_x and y = 0 .. blocks_y pitch_y, with one row of blocks
/// round them.
CityGrid gridAround(int blocks_x, int blocks_y, double pitch_y) {
  CityGrid grid;
  grid.pitch_y = pitch_y;
  grid.block_i0 = -1;
  grid.block_i1 = blocks_x + 1;
  grid.block_j0 = -1;
  grid.block_j1 = blocks_y + 1;
  return grid;
}

/// The city seen from `streets`, the drive along them and, when asked, the traffic.
void buildCityAndDrive(Scenario& scenario, const CityGrid& grid,
                       const std::vector<Eigen::Vector2d>& streets, std::uint32_t seed,
                       const ScenarioOptions& options) {
  buildCity(scenario.scene, grid, streets, seed);
  addDrive(scenario, streets, options.motion_seed.value_or(seed), options);
  if (options.traffic) addTraffic(scenario, grid, streets, options.traffic_seed.value_or(seed));
}

}  // namespace

Scenario makeCityBlock(std::uint32_t seed, const ScenarioOptions& options) {
  Scenario scenario;
  scenario.name = "city_block";
  scenario.description = "forward-looking car camera, one loop round a 110 m x 75 m city block";
  const CityGrid grid = gridAround(1, 1, 75.0);
  // Clockwise (right turns) round block (0, 0) from the middle of its west street, then on.
  const std::vector<Eigen::Vector2d> streets = {grid.node(0, 0.5), grid.node(0, 1),
                                                grid.node(1, 1),   grid.node(1, 0),
                                                grid.node(0, 0),   grid.node(0, 1.0)};
  buildCityAndDrive(scenario, grid, streets, seed, options);
  return scenario;
}

Scenario makeCityLoop(std::uint32_t seed, const ScenarioOptions& options) {
  Scenario scenario;
  scenario.name = "city_loop";
  scenario.description =
      "forward-looking car camera, a loop round 3 x 2 city blocks and a second loop re-driving "
      "two of its streets";
  const CityGrid grid = gridAround(3, 2, 80.0);
  // One lap: from the middle of the west street round both loops back to the south-west corner.
  // Each further lap drives on north from there through the start; the route ends past it.
  const std::vector<Eigen::Vector2d> lap = {grid.node(0, 2), grid.node(3, 2), grid.node(3, 0),
                                            grid.node(0, 0), grid.node(0, 1), grid.node(2, 1),
                                            grid.node(2, 0), grid.node(0, 0)};
  std::vector<Eigen::Vector2d> streets = {grid.node(0, 0.5)};
  for (int i = 0; i < options.laps; ++i)
    streets.insert(streets.end(), lap.begin(), lap.end());
  streets.push_back(grid.node(0, 0.9));
  if (options.laps > 1) {
    scenario.description += ", driven " + std::to_string(options.laps) + " times";
  }
  buildCityAndDrive(scenario, grid, streets, seed, options);
  return scenario;
}

Scenario makeCityTour(std::uint32_t seed, const ScenarioOptions& options) {
  Scenario scenario;
  scenario.name = "city_tour";
  scenario.description =
      "forward-looking car camera, a tour of 8 x 5 city blocks (a serpentine) back to its start";
  const CityGrid grid = gridAround(8, 5, 80.0);
  std::vector<Eigen::Vector2d> streets = {grid.node(0, 0.5), grid.node(0, 5), grid.node(8, 5)};
  for (int j = 4; j >= 1; --j) {  // down the serpentine: west on j = 4 and 2, east on 3 and 1
    const bool west = j % 2 == 0;
    streets.push_back(grid.node(west ? 8 : 1, j));
    streets.push_back(grid.node(west ? 1 : 8, j));
  }
  streets.push_back(grid.node(8, 0));
  streets.push_back(grid.node(0, 0));
  streets.push_back(grid.node(0, 1.2));  // through the start again: the loop
  buildCityAndDrive(scenario, grid, streets, seed, options);
  return scenario;
}

}  // namespace scale_drift_slam::sim::detail
