// The streets of the driving world (city_world.h): asphalt with markings between the crossings,
// the crossings, kerbs and pavement strips; the blocks' buildings are in city_blocks.cpp.

#include "city_world.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <tuple>

#include "scale_drift_slam/sim/texture_generator.h"

namespace scale_drift_slam::sim::detail {
namespace {

constexpr double kRoadTexelsPerMetre = 30.0;  // 3 cm: the nearest road seen is ~6 m ahead
constexpr double kStripDepth = 7.0;           // pavement plus the deepest set-back
constexpr double kSampleStep = 2.5;

/// The hull [first, last] of the sampled parameters in [0, length] whose point is within the
/// visible range of the route; first > last when none is.
std::pair<double, double> visibleRange(double length, const std::vector<Eigen::Vector2d>& route,
                                       const std::function<Eigen::Vector2d(double)>& point) {
  double first = 1.0, last = 0.0;
  const int n = std::max(1, static_cast<int>(std::ceil(length / kSampleStep)));
  for (int k = 0; k <= n; ++k) {
    const double u = length * k / n;
    if (distanceToPolyline(point(u), route) >= kVisibleRange) continue;
    if (first > last) first = u;
    last = u;
  }
  return {first, last};
}

Eigen::Vector3d lift(const Eigen::Vector2d& p, double z) {
  return {p.x(), p.y(), z};
}

/// The street from node a to node b between the two crossings, where it is seen.
void addStreet(Scene& scene, const CityGrid& grid, const Eigen::Vector2d& a,
               const Eigen::Vector2d& b, const std::vector<Eigen::Vector2d>& route,
               std::uint32_t& texture_seed) {
  const double hw = grid.road_half_width;
  const Eigen::Vector2d d = (b - a).normalized(), left(-d.y(), d.x());
  const Eigen::Vector2d start = a + hw * d;
  const double length = (b - a).norm() - 2 * hw;
  const auto [first, last] =
      visibleRange(length, route, [&](double u) -> Eigen::Vector2d { return start + u * d; });
  if (first >= last) return;
  const cv::Mat image = textures::road(last - first, 2 * hw, kRoadTexelsPerMetre, texture_seed++,
                                       first == 0.0, last == length);
  // Texture rows along the street, its top edge on the street's left.
  scene.addQuad(lift(start + first * d + hw * left, 0.0), lift((last - first) * d, 0.0),
                lift(-2 * hw * left, 0.0), image, 0.9f);
}

void addPavementAndKerb(Scene& scene, const CityGrid& grid, const BlockSide& side,
                        std::uint32_t& texture_seed) {
  double u0 = side.u_min, u1 = side.u_max;
  if (!side.full_corners) {  // the corner squares belong to the crossing side's strip
    u0 = std::max(u0, kStripDepth);
    u1 = std::min(u1, side.length - kStripDepth);
  }
  if (u1 - u0 < 1.0) return;
  const double z = grid.kerb_height;
  // Seen from above: top edge at u1, rows running inwards.
  const Eigen::Vector3d along = lift(side.along, 0.0), outward = lift(side.outward, 0.0);
  scene.addQuad(lift(side.at(u1, 0.0), z), -(u1 - u0) * along, -kStripDepth * outward,
                textures::pavedGround(u1 - u0, kStripDepth, kRoadTexelsPerMetre, texture_seed++),
                0.95f);
  const int kerb =
      scene.addQuad(lift(side.at(side.u_min, 0.0), z), (side.u_max - side.u_min) * along,
                    Eigen::Vector3d(0, 0, -z),
                    textures::kerbStones(side.u_max - side.u_min, z, 40.0, texture_seed++), 1.0f);
  scene.surface(kerb).double_sided = false;
}

/// The four sides of block (i, j), outward normals south, east, north, west.
std::vector<BlockSide> blockSides(const CityGrid& grid, int i, int j) {
  const double hw = grid.road_half_width;
  const Eigen::Vector2d low = grid.node(i, j) + Eigen::Vector2d(hw, hw);
  const Eigen::Vector2d high = grid.node(i + 1, j + 1) - Eigen::Vector2d(hw, hw);
  const Eigen::Vector2d centre = (low + high) / 2, half = (high - low) / 2;
  std::vector<BlockSide> sides;
  for (const Eigen::Vector2d& n : {Eigen::Vector2d(0, -1), Eigen::Vector2d(1, 0),
                                   Eigen::Vector2d(0, 1), Eigen::Vector2d(-1, 0)}) {
    BlockSide side;
    side.outward = n;
    side.along = Eigen::Vector2d(-n.y(), n.x());  // z x n: to the right seen from the street
    side.length = 2 * std::abs(side.along.dot(half));
    side.origin = centre + std::abs(n.dot(half)) * n - side.length / 2 * side.along;
    side.full_corners = n.y() != 0.0;
    sides.push_back(side);
  }
  return sides;
}

}  // namespace

double distanceToPolyline(const Eigen::Vector2d& p, const std::vector<Eigen::Vector2d>& polyline) {
  double best = (p - polyline.front()).norm();
  for (size_t k = 0; k + 1 < polyline.size(); ++k) {
    const Eigen::Vector2d a = polyline[k], ab = polyline[k + 1] - a;
    const double f = std::clamp((p - a).dot(ab) / std::max(1e-12, ab.squaredNorm()), 0.0, 1.0);
    best = std::min(best, (a + f * ab - p).norm());
  }
  return best;
}

std::vector<Eigen::Vector2d> offsetRight(const std::vector<Eigen::Vector2d>& polyline,
                                         double offset) {
  auto right = [&](size_t k) {
    const Eigen::Vector2d d = (polyline[k + 1] - polyline[k]).normalized();
    return Eigen::Vector2d(d.y(), -d.x());
  };
  std::vector<Eigen::Vector2d> result;
  for (size_t k = 0; k < polyline.size(); ++k) {
    const Eigen::Vector2d r_in = right(k == 0 ? 0 : k - 1);
    const Eigen::Vector2d r_out = right(k + 1 == polyline.size() ? k - 1 : k);
    // The mitre: where the two offset lines meet.
    result.push_back(polyline[k] + offset * (r_in + r_out) / (1.0 + r_in.dot(r_out)));
  }
  return result;
}

void buildCity(Scene& scene, const CityGrid& grid, const std::vector<Eigen::Vector2d>& route,
               std::uint32_t seed) {
  std::uint32_t texture_seed = seed * 7919u + 101u;
  const double hw = grid.road_half_width;
  for (int i = grid.block_i0; i <= grid.block_i1; ++i) {
    for (int j = grid.block_j0; j <= grid.block_j1; ++j) {
      const Eigen::Vector2d node = grid.node(i, j);
      if (distanceToPolyline(node, route) < kVisibleRange) {
        scene.addQuad(lift(node + Eigen::Vector2d(-hw, hw), 0.0), Eigen::Vector3d(2 * hw, 0, 0),
                      Eigen::Vector3d(0, -2 * hw, 0),
                      textures::asphalt(2 * hw, 2 * hw, kRoadTexelsPerMetre, texture_seed++), 0.9f);
      }
      if (i < grid.block_i1) addStreet(scene, grid, node, grid.node(i + 1, j), route, texture_seed);
      if (j < grid.block_j1) addStreet(scene, grid, node, grid.node(i, j + 1), route, texture_seed);
    }
  }
  for (int i = grid.block_i0; i < grid.block_i1; ++i) {
    for (int j = grid.block_j0; j < grid.block_j1; ++j) {
      for (BlockSide& side : blockSides(grid, i, j)) {
        std::tie(side.u_min, side.u_max) =
            visibleRange(side.length, route, [&](double u) { return side.at(u, -hw); });
        if (side.u_max - side.u_min < 1.0) continue;
        addPavementAndKerb(scene, grid, side, texture_seed);
        buildBlockSide(scene, grid, side, route, texture_seed);
      }
    }
  }
}

}  // namespace scale_drift_slam::sim::detail
