// The buildings, street furniture and parked cars along one block side (city_world.h).

#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>

#include "city_world.h"
#include "scale_drift_slam/sim/texture_generator.h"
#include "scenario_builders.h"

namespace scale_drift_slam::sim::detail {
namespace {

constexpr double kFacadeTexelsPerMetre = 40.0;  // 2.5 cm: facades are 6-15 m from the lane
constexpr double kSideTexelsPerMetre = 20.0;    // end walls, seen obliquely or far
constexpr double kCarTexelsPerMetre = 60.0;     // parked cars pass at 2-3 m

Eigen::Vector3d lift(const Eigen::Vector2d& p, double z) {
  return {p.x(), p.y(), z};
}

/// A vertical wall from `left` to `right` as seen from its visible side, z in [0, height].
void addWall(Scene& scene, const Eigen::Vector2d& left, const Eigen::Vector2d& right, double height,
             int texture, float gain, const Eigen::Vector3f& tint) {
  const int index = scene.addQuad(lift(left, height), lift(right - left, 0.0),
                                  Eigen::Vector3d(0, 0, -height), texture, gain);
  scene.surface(index).double_sided = false;
  scene.surface(index).tint = tint;
}

Eigen::Vector3f facadeTint(cv::RNG& rng) {
  // B, G, R: brick red, sandstone, grey-blue, warm white, ochre.
  const Eigen::Vector3f tints[5] = {{0.65f, 0.9f, 1.45f},
                                    {0.7f, 1.0f, 1.25f},
                                    {1.2f, 1.0f, 0.9f},
                                    {0.9f, 1.0f, 1.08f},
                                    {0.55f, 0.95f, 1.2f}};
  return tints[rng.uniform(0, 5)];
}

double buildingHeight(cv::RNG& rng) {
  const int kind = rng.uniform(0, 10);
  if (kind < 4) return rng.uniform(6.0, 12.0);
  if (kind < 8) return rng.uniform(12.0, 18.0);
  return rng.uniform(18.0, 25.0);
}

/// Which end walls of a building are built.
struct EndWalls {
  bool at_u0 = true;
  bool at_u1 = true;
};

/// A building on [u0, u1] of the side, its front `front` metres behind the kerb: the front
/// facade and the end walls asked for (back and roof are never seen from the street).
void addBuilding(Scene& scene, const BlockSide& side, double u0, double u1, double front,
                 EndWalls ends, cv::RNG& rng, std::uint32_t& texture_seed) {
  const double height = buildingHeight(rng), depth = rng.uniform(12.0, 20.0);
  const float gain = static_cast<float>(rng.uniform(0.75, 1.05));
  const Eigen::Vector3f tint = facadeTint(rng);
  const int front_texture =
      scene.addTexture(textures::facade(u1 - u0, height, kFacadeTexelsPerMetre, texture_seed++));
  addWall(scene, side.at(u0, front), side.at(u1, front), height, front_texture, gain, tint);
  const std::uint32_t end_seed = texture_seed++;
  if (!ends.at_u0 && !ends.at_u1) return;
  const int end_texture =
      scene.addTexture(textures::facade(depth, height, kSideTexelsPerMetre, end_seed));
  if (ends.at_u0) {
    addWall(scene, side.at(u0, front + depth), side.at(u0, front), height, end_texture, 0.8f * gain,
            tint);
  }
  if (ends.at_u1) {
    addWall(scene, side.at(u1, front), side.at(u1, front + depth), height, end_texture, 0.7f * gain,
            tint);
  }
}

/// A gap between buildings: a yard's floor and the building behind it.
void addGap(Scene& scene, const CityGrid& grid, const BlockSide& side, double u0, double u1,
            cv::RNG& rng, std::uint32_t& texture_seed) {
  const double from = grid.pavement_width + 4.0, to = from + 10.0;
  scene.addQuad(lift(side.at(u1, from), grid.kerb_height), lift(-(u1 - u0) * side.along, 0.0),
                lift(-(to - from) * side.outward, 0.0),
                textures::pavedGround(u1 - u0, to - from, 30.0, texture_seed++), 0.85f);
  const double height = buildingHeight(rng);
  addWall(scene, side.at(u0 - 1.0, to), side.at(u1 + 1.0, to), height,
          scene.addTexture(textures::facade(u1 - u0 + 2.0, height, 25.0, texture_seed++)), 0.8f,
          facadeTint(rng));
}

void addTree(Scene& scene, const Eigen::Vector2d& at, double base, cv::RNG& rng,
             std::uint32_t& texture_seed) {
  const double trunk = rng.uniform(2.3, 3.2), crown = rng.uniform(2.5, 4.0);
  const double yaw = rng.uniform(0.0, M_PI / 2);
  addBox(scene, lift(at, base), Eigen::Vector3d(0.3, 0.3, trunk), yaw,
         textures::streetMaterial("bark", 1.2, trunk, 40.0, texture_seed),
         textures::streetMaterial("bark", 0.3, 0.3, 40.0, texture_seed + 1));
  texture_seed += 2;
  const cv::Mat leaves = textures::streetMaterial("foliage", crown, crown, 40.0, texture_seed++);
  addBox(scene, lift(at, base + trunk), Eigen::Vector3d(crown, crown, crown), yaw, leaves, leaves,
         0.8f);
  // The crown's underside, seen from below (edge1 x edge2 points up).
  const Eigen::Vector3d ex(std::cos(yaw) * crown, std::sin(yaw) * crown, 0);
  const Eigen::Vector3d ey(-ex.y(), ex.x(), 0);
  const int index = scene.addQuad(lift(at, base + trunk) - ex / 2 - ey / 2, ex, ey,
                                  scene.addTexture(leaves), 0.55f);
  scene.surface(index).double_sided = false;
}

/// Lamp posts and trees on the pavement, every 8-12 m a chance of one.
void addStreetFurniture(Scene& scene, const CityGrid& grid, const BlockSide& side, cv::RNG& rng,
                        std::uint32_t& texture_seed) {
  const double yaw = std::atan2(side.along.y(), side.along.x());
  for (double u = std::max(side.u_min, 10.0) + rng.uniform(0.0, 6.0);
       u < std::min(side.u_max, side.length - 10.0); u += rng.uniform(8.0, 12.0)) {
    const int kind = rng.uniform(0, 10);
    if (kind < 3) {
      const double height = rng.uniform(5.5, 7.5);
      addBox(scene, lift(side.at(u, 0.6), grid.kerb_height), Eigen::Vector3d(0.16, 0.16, height),
             yaw, textures::streetMaterial("metal", 0.64, height, 40.0, texture_seed),
             textures::streetMaterial("metal", 0.16, 0.16, 40.0, texture_seed + 1));
      texture_seed += 2;
    } else if (kind < 7) {
      addTree(scene, side.at(u, 1.4), grid.kerb_height, rng, texture_seed);
    }
  }
}

/// Cars parked in the parking strip along the kerb, nose to tail with gaps, none near crossings.
void addParkedCars(Scene& scene, const BlockSide& side, cv::RNG& rng, std::uint32_t& texture_seed) {
  const double yaw = std::atan2(side.along.y(), side.along.x());
  for (double u = std::max(side.u_min, 12.0) + rng.uniform(0.0, 4.0);
       u + 4.5 < std::min(side.u_max, side.length - 12.0); u += rng.uniform(0.8, 3.0)) {
    const double length = rng.uniform(3.8, 4.8), height = rng.uniform(1.4, 1.65);
    if (rng.uniform(0, 10) < 6) {
      addBox(scene, lift(side.at(u + length / 2, -1.0), 0.0), Eigen::Vector3d(length, 1.8, height),
             yaw, textures::carBody(length, height, kCarTexelsPerMetre, texture_seed),
             textures::streetMaterial("metal", length, 1.8, 20.0, texture_seed + 1),
             static_cast<float>(rng.uniform(0.8, 1.05)));
      texture_seed += 2;
    }
    u += length;
  }
}

}  // namespace

void buildBlockSide(Scene& scene, const CityGrid& grid, const BlockSide& side,
                    const std::vector<Eigen::Vector2d>& route, std::uint32_t& texture_seed) {
  cv::RNG rng(0xb10c0000ULL + texture_seed++);
  // Buildings from the crossing's building line (corner buildings meet their neighbours round
  // the corner) to the other; a gap (yard) now and then.
  const double end = side.length - grid.pavement_width;
  double u = grid.pavement_width;
  while (u < end - 1.0) {
    double width = rng.uniform(8.0, 30.0);
    if (end - (u + width) < 8.0) width = end - u;  // no sliver at the end
    const double mid = u + width / 2;
    // Built when any of its front is in sight of the route.
    const bool seen =
        distanceToPolyline(side.at(u, -grid.road_half_width), route) < kVisibleRange ||
        distanceToPolyline(side.at(mid, -grid.road_half_width), route) < kVisibleRange ||
        distanceToPolyline(side.at(u + width, -grid.road_half_width), route) < kVisibleRange;
    const double setback = rng.uniform(0, 3) == 0 ? rng.uniform(0.5, 4.0) : 0.0;
    // A corner building's end wall at the crossing would lie in the building line of the side
    // round the corner, in the plane of that side's facades: two coplanar walls, which the
    // renderer shows in turn from frame to frame (z-fighting), so that the same place looked
    // different on a revisit. The facade round the corner closes the building there instead.
    const EndWalls ends{u > grid.pavement_width + 1e-6, u + width < end - 1e-6};
    if (seen) {
      addBuilding(scene, side, u, u + width, grid.pavement_width + setback, ends, rng,
                  texture_seed);
    }
    u += width;
    if (u < end - 12.0 && rng.uniform(0, 5) == 0) {
      const double gap = rng.uniform(3.0, 8.0);
      if (seen) addGap(scene, grid, side, u, u + gap, rng, texture_seed);
      u += gap;
    }
  }
  addStreetFurniture(scene, grid, side, rng, texture_seed);
  addParkedCars(scene, side, rng, texture_seed);
}

}  // namespace scale_drift_slam::sim::detail
