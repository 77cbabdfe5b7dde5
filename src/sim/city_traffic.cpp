// Moving cars in the driving world (city_traffic.h).

#include "city_traffic.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include <opencv2/core.hpp>

#include "city_route.h"
#include "scale_drift_slam/sim/texture_generator.h"
#include "scenario_builders.h"

namespace scale_drift_slam::sim::detail {
namespace {

constexpr double kLaneOffset = 1.75;  // right of the centre line, as the camera's car
constexpr double kSideStreet = 48.0;  // crossing and merging cars start this far out
constexpr double kStep = 0.1;         // seconds between the samples of the checks
constexpr double kClearance = 0.6;    // metres kept between footprints
constexpr double kCarTexelsPerMetre = 60.0;
constexpr double kBuildingInset = 7.5;  // kerb to the deepest building front (pavement + set-back)

struct Car {
  std::shared_ptr<const CityRoute> route;
  double t0 = 0.0;  ///< When it is at its route's start.
  double t_begin = -std::numeric_limits<double>::infinity();
  double t_end = std::numeric_limits<double>::infinity();
  Eigen::Vector3d size;
  int first_surface = 0;  ///< Its box: 5 surfaces from here.
  int kind = 0;           ///< Placed in this order: 0 merging, 1 crossing, 2 oncoming.
};

MovingObject carAt(const Car& car, double t) {
  MovingObject object;
  object.size = car.size;
  object.first_surface = car.first_surface;
  object.present = t >= car.t_begin && t <= car.t_end;
  const CityRoute::State state = car.route->atTime(t - car.t0);
  object.position = state.position;
  object.heading = state.heading;
  return object;
}

Eigen::Vector2d perpendicular(const Eigen::Vector2d& d) {
  return {-d.y(), d.x()};
}

/// The parts of the blocks that the buildings fill (seen from the street, opaque to sight).
struct Blocks {
  std::vector<Eigen::Vector2d> low, high;
  explicit Blocks(const CityGrid& grid) {
    const double inset = grid.road_half_width + kBuildingInset;
    for (int i = grid.block_i0; i < grid.block_i1; ++i) {
      for (int j = grid.block_j0; j < grid.block_j1; ++j) {
        low.push_back(grid.node(i, j) + Eigen::Vector2d(inset, inset));
        high.push_back(grid.node(i + 1, j + 1) - Eigen::Vector2d(inset, inset));
      }
    }
  }
  /// Whether the segment a-b runs through a block (slab test).
  bool blocks(const Eigen::Vector2d& a, const Eigen::Vector2d& b) const {
    const Eigen::Vector2d d = b - a;
    for (size_t k = 0; k < low.size(); ++k) {
      double f0 = 0.0, f1 = 1.0;
      for (int axis = 0; axis < 2 && f0 <= f1; ++axis) {
        if (std::abs(d[axis]) < 1e-12) {
          if (a[axis] < low[k][axis] || a[axis] > high[k][axis]) f1 = -1.0;
          continue;
        }
        double u = (low[k][axis] - a[axis]) / d[axis], v = (high[k][axis] - a[axis]) / d[axis];
        if (u > v) std::swap(u, v);
        f0 = std::max(f0, u);
        f1 = std::min(f1, v);
      }
      if (f0 <= f1) return true;
    }
    return false;
  }
};

/// Whether the camera cannot see any of the car: it is behind the camera or behind buildings
/// (not merely far: a car 130 m down a street still covers some 10 x 6 pixels).
bool hiddenFrom(const MovingObject& ego, const MovingObject& car, const Blocks& blocks) {
  const Eigen::Vector2d camera = ego.position + kEgoBehindCamera * ego.heading;
  const Eigen::Vector2d along = 0.5 * car.size.x() * car.heading;
  const Eigen::Vector2d across = 0.5 * car.size.y() * perpendicular(car.heading);
  for (const double a : {-1.0, 1.0}) {
    for (const double b : {-1.0, 1.0}) {
      const Eigen::Vector2d corner = car.position + a * along + b * across;
      if ((corner - camera).dot(ego.heading) < -1.0) continue;  // behind
      if (!blocks.blocks(camera, corner)) return false;
    }
  }
  return true;
}

/// A candidate's time in the world: from the last moment it is hidden before it comes closest to
/// the camera to the first after. False when it would have to appear or vanish in sight (at its
/// route's ends within the sequence) or never comes within `near` metres.
bool lifetime(const Scenario& scenario, const Blocks& blocks, Car& car, double near) {
  const double begin = std::max(0.0, car.t0),
               end = std::min(scenario.duration, car.t0 + car.route->duration());
  if (end - begin < 1.0) return false;
  std::vector<double> times;
  for (double t = begin; t <= end; t += kStep)
    times.push_back(t);
  double closest = std::numeric_limits<double>::infinity();
  size_t key = 0;
  std::vector<bool> hidden(times.size());
  for (size_t k = 0; k < times.size(); ++k) {
    const MovingObject ego = egoCar(scenario, times[k]), object = carAt(car, times[k]);
    const double distance = (object.position - ego.position).norm();
    if (distance < closest) {
      closest = distance;
      key = k;
    }
    hidden[k] = hiddenFrom(ego, object, blocks);
  }
  if (closest > near) return false;
  // In the world from a pair of hidden samples to a pair: the first and the last frame that
  // holds the car, whatever the frame times, see it hidden.
  size_t first = key, last = key;
  while (first > 0 && !(hidden[first] && first + 1 < times.size() && hidden[first + 1]))
    --first;
  while (last + 1 < times.size() && !(hidden[last] && last > 0 && hidden[last - 1]))
    ++last;
  if (!(hidden[first] && first + 1 < times.size() && hidden[first + 1])) {
    if (car.t0 > 0.0) return false;  // would appear at its route's start in sight
    car.t_begin = -std::numeric_limits<double>::infinity();
  } else {
    car.t_begin = times[first];
  }
  if (!(hidden[last] && last > 0 && hidden[last - 1])) {
    if (car.t0 + car.route->duration() < scenario.duration) return false;
    car.t_end = std::numeric_limits<double>::infinity();
  } else {
    car.t_end = times[last];
  }
  return true;
}

/// Whether the car keeps clear of the camera's car and of the cars placed so far.
bool keepsClear(const Scenario& scenario, const Car& car, const std::vector<Car>& placed) {
  const double begin = std::max(0.0, car.t_begin), end = std::min(scenario.duration, car.t_end);
  for (double t = begin; t <= end; t += kStep) {
    const MovingObject object = carAt(car, t);
    if (footprintsOverlap(object, egoCar(scenario, t), kClearance)) return false;
    for (const Car& other : placed) {
      const MovingObject o = carAt(other, t);
      if (o.present && footprintsOverlap(object, o, kClearance)) return false;
    }
  }
  return true;
}

/// The grid nodes the camera's route passes, with the time the camera is closest to each and the
/// direction it leaves it in.
struct Junction {
  Eigen::Vector2d node, out;
  double time = 0.0;
};

std::vector<Junction> routeJunctions(const Scenario& scenario, const CityGrid& grid,
                                     const std::vector<Eigen::Vector2d>& streets) {
  std::vector<Junction> junctions;
  for (int i = grid.block_i0; i <= grid.block_i1; ++i) {
    for (int j = grid.block_j0; j <= grid.block_j1; ++j) {
      const Eigen::Vector2d node = grid.node(i, j);
      if (distanceToPolyline(node, streets) > 1.0) continue;
      double best = std::numeric_limits<double>::infinity();
      Junction junction;
      junction.node = node;
      for (double t = 0.0; t <= scenario.duration; t += kStep) {
        const MovingObject ego = egoCar(scenario, t);
        const double d = (ego.position - node).norm();
        if (d < best) {
          best = d;
          junction.time = t;
        }
      }
      // The axis direction it heads in 2 s later.
      const Eigen::Vector2d h = egoCar(scenario, junction.time + 2.0).heading;
      junction.out = std::abs(h.x()) > std::abs(h.y()) ? Eigen::Vector2d(h.x() > 0 ? 1 : -1, 0)
                                                       : Eigen::Vector2d(0, h.y() > 0 ? 1 : -1);
      junctions.push_back(junction);
    }
  }
  return junctions;
}

std::shared_ptr<const CityRoute> laneRoute(const std::vector<Eigen::Vector2d>& centre,
                                           cv::RNG& rng) {
  DriveParams params;
  params.cruise_speed_min = 8.5;
  params.cruise_speed_max = 13.5;
  // Tighter than the camera's car (9-13 m): a footprint on an arc of at most 9 m from the right
  // lane keeps clear of the kerb's corner.
  params.turn_radius_min = 6.0;
  params.turn_radius_max = 9.0;
  return std::make_shared<const CityRoute>(offsetRight(centre, kLaneOffset), params,
                                           static_cast<unsigned>(rng.next()));
}

/// The camera's streets from the node nearest `from` on, extended straight by `extra` metres.
std::vector<Eigen::Vector2d> streetsFrom(const std::vector<Eigen::Vector2d>& streets,
                                         const Eigen::Vector2d& from, double extra) {
  size_t k = 0;
  for (size_t i = 0; i < streets.size(); ++i) {
    if ((streets[i] - from).norm() < (streets[k] - from).norm()) k = i;
  }
  std::vector<Eigen::Vector2d> rest(streets.begin() + static_cast<long>(k), streets.end());
  if (rest.size() < 2) return rest;
  const Eigen::Vector2d d = (rest.back() - rest[rest.size() - 2]).normalized();
  rest.back() += extra * d;
  return rest;
}

/// The candidates: oncoming (the route backwards), crossing and merging at each junction.
std::vector<Car> candidates(const Scenario& scenario, const CityGrid& grid,
                            const std::vector<Eigen::Vector2d>& streets, cv::RNG& rng) {
  std::vector<Car> cars;
  auto add = [&](std::shared_ptr<const CityRoute> route, double t0, int kind) {
    Car car;
    car.kind = kind;
    car.route = std::move(route);
    car.t0 = t0;
    cars.push_back(car);
  };
  std::vector<Eigen::Vector2d> backwards(streets.rbegin(), streets.rend());
  const Eigen::Vector2d d0 = (backwards[0] - backwards[1]).normalized();
  const Eigen::Vector2d d1 = (backwards.back() - backwards[backwards.size() - 2]).normalized();
  backwards.front() += 40.0 * d0;
  backwards.back() += 40.0 * d1;
  const int oncoming = static_cast<int>(scenario.duration / 3.0);
  for (int k = 0; k < oncoming; ++k) {
    auto route = laneRoute(backwards, rng);
    add(route, rng.uniform(-route->duration(), scenario.duration), 2);
  }
  for (const Junction& junction : routeJunctions(scenario, grid, streets)) {
    for (int k = 0; k < 4; ++k) {  // crossing: along either axis, either way
      const Eigen::Vector2d d = k < 2 ? junction.out : perpendicular(junction.out);
      const Eigen::Vector2d dir = k % 2 == 0 ? d : Eigen::Vector2d(-d);
      auto route =
          laneRoute({junction.node - kSideStreet * dir, junction.node + kSideStreet * dir}, rng);
      add(route, junction.time + rng.uniform(-7.0, 7.0) - route->duration() / 2, 1);
    }
    // Merging: from either side street, or straight on from behind into the camera's way on.
    const Eigen::Vector2d side = perpendicular(junction.out);
    for (const Eigen::Vector2d& from :
         {side, Eigen::Vector2d(-side), Eigen::Vector2d(-junction.out)}) {
      std::vector<Eigen::Vector2d> path = {junction.node + kSideStreet * from};
      for (const Eigen::Vector2d& p : streetsFrom(streets, junction.node, 40.0))
        path.push_back(p);
      if (path.size() < 3 || (path[1] - junction.node).norm() > 1.0) continue;
      if ((path[2] - path[1]).normalized().dot(from) > 0.5) continue;  // no U-turns
      for (int attempt = 0; attempt < 6; ++attempt) {
        add(laneRoute(path, rng), junction.time - rng.uniform(2.0, 10.0) - kSideStreet / 10.0, 0);
      }
    }
  }
  std::stable_sort(cars.begin(), cars.end(),
                   [](const Car& a, const Car& b) { return a.kind < b.kind; });
  return cars;
}

void addCarBody(Scene& scene, Car& car, cv::RNG& rng, std::uint32_t& texture_seed) {
  const double length = rng.uniform(3.8, 4.8), height = rng.uniform(1.4, 1.65);
  car.size = Eigen::Vector3d(length, 1.8, height);
  car.first_surface = static_cast<int>(scene.surfaces().size());
  addBox(scene, Eigen::Vector3d::Zero(), car.size, 0.0,
         textures::carBody(length, height, kCarTexelsPerMetre, texture_seed),
         textures::streetMaterial("metal", length, 1.8, 20.0, texture_seed + 1),
         static_cast<float>(rng.uniform(0.8, 1.05)));
  texture_seed += 2;
}

}  // namespace

MovingObject egoCar(const Scenario& scenario, double t) {
  const geometry::SE3 pose = scenario.T_world_cam(std::clamp(t, 0.0, scenario.duration));
  const Eigen::Vector3d axis = pose.rotationMatrix().col(2);
  MovingObject ego;
  ego.present = true;
  ego.heading = Eigen::Vector2d(axis.x(), axis.y()).normalized();
  ego.position = pose.translation().head<2>() - kEgoBehindCamera * ego.heading;
  ego.size = Eigen::Vector3d(kEgoLength, kEgoWidth, 1.5);
  return ego;
}

bool footprintsOverlap(const MovingObject& a, const MovingObject& b, double margin) {
  const Eigen::Vector2d axes[4] = {a.heading, perpendicular(a.heading), b.heading,
                                   perpendicular(b.heading)};
  auto extent = [](const MovingObject& o, const Eigen::Vector2d& u) {
    return 0.5 * (o.size.x() * std::abs(o.heading.dot(u)) +
                  o.size.y() * std::abs(perpendicular(o.heading).dot(u)));
  };
  for (const Eigen::Vector2d& u : axes) {
    if (std::abs((b.position - a.position).dot(u)) > extent(a, u) + extent(b, u) + margin)
      return false;
  }
  return true;
}

void addTraffic(Scenario& scenario, const CityGrid& grid,
                const std::vector<Eigen::Vector2d>& streets, std::uint32_t seed) {
  cv::RNG rng(0x7aff1c00ULL + seed);
  const Blocks blocks(grid);
  std::vector<Car> cars;
  std::uint32_t texture_seed = seed * 104729u + 3u;
  for (Car& car : candidates(scenario, grid, streets, rng)) {
    car.size = Eigen::Vector3d(4.8, 1.8, 1.6);  // the largest body, for the checks
    if (!lifetime(scenario, blocks, car, 40.0) || !keepsClear(scenario, car, cars)) continue;
    addCarBody(scenario.scene, car, rng, texture_seed);
    cars.push_back(car);
  }
  std::vector<Surface> body;  // every car's surfaces in its own frame
  for (const Car& car : cars) {
    for (int k = 0; k < 5; ++k)
      body.push_back(scenario.scene.surfaces()[static_cast<size_t>(car.first_surface + k)]);
  }
  scenario.animate = [cars, body](double t, Scene& scene) {
    for (size_t c = 0; c < cars.size(); ++c) {
      const MovingObject object = carAt(cars[c], t);
      Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
      R.topLeftCorner<2, 2>() << object.heading, perpendicular(object.heading);
      const Eigen::Vector3d p(object.position.x(), object.position.y(), 0.0);
      for (int k = 0; k < 5; ++k) {
        const Surface& local = body[5 * c + static_cast<size_t>(k)];
        Surface& s = scene.surface(cars[c].first_surface + k);
        s.hidden = !object.present;
        s.origin = R * local.origin + p;
        s.edge1 = R * local.edge1;
        s.edge2 = R * local.edge2;
      }
    }
  };
  scenario.moving_objects = [cars](double t) {
    std::vector<MovingObject> objects;
    for (const Car& car : cars)
      objects.push_back(carAt(car, t));
    return objects;
  };
  scenario.animate(0.0, scenario.scene);
  scenario.description += ", traffic: " + std::to_string(cars.size()) + " moving cars";
}

}  // namespace scale_drift_slam::sim::detail
