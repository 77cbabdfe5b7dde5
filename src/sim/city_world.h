#pragma once
// Private to src/sim: the driving world of city_block and city_loop. A grid of streets (centre
// lines at x = i pitch_x and y = j pitch_y) with blocks of buildings between them; only the part
// seen from a route is built (within kVisibleRange of the route's streets), so a long drive does
// not pay for the whole city.
//
// A street: asphalt 2 road_half_width wide (two lanes and a parking strip on each side), kerbs
// kerb_height high, pavements pavement_width wide. A block side (the kerb line of one street):
// buildings of varied width, height (6-25 m), depth and set-back (0-4 m) behind the pavement,
// with gaps now and then (a yard and the next building behind), lamp posts and trees on the
// pavement and cars parked in the parking strip. Crossings are open (no buildings on the street).

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "scale_drift_slam/sim/scene.h"

namespace scale_drift_slam::sim::detail {

struct CityGrid {
  double pitch_x = 110.0;  ///< Street spacing along x (metres, centre line to centre line).
  double pitch_y = 75.0;
  double road_half_width = 5.5;  ///< Centre line to kerb.
  double pavement_width = 3.0;
  double kerb_height = 0.15;
  /// Blocks (i, j) for i in [block_i0, block_i1), j in [block_j0, block_j1); block (i, j) lies
  /// between streets x = i and x = i + 1 and streets y = j and y = j + 1.
  int block_i0 = -1, block_i1 = 2, block_j0 = -1, block_j1 = 2;

  Eigen::Vector2d node(double i, double j) const { return {i * pitch_x, j * pitch_y}; }
};

/// Objects farther than this from every route street are not built (metres).
constexpr double kVisibleRange = 55.0;

/// The distance from p to the polyline.
double distanceToPolyline(const Eigen::Vector2d& p, const std::vector<Eigen::Vector2d>& polyline);

/// The polyline moved `offset` to its right (corners mitred): the lane a car drives in.
std::vector<Eigen::Vector2d> offsetRight(const std::vector<Eigen::Vector2d>& polyline,
                                         double offset);

/// Builds the city seen from `route` (the street centre lines driven, through grid nodes).
void buildCity(Scene& scene, const CityGrid& grid, const std::vector<Eigen::Vector2d>& route,
               std::uint32_t seed);

/// One side of a block, along the kerb of the street it faces: u runs along the kerb (to the
/// right as seen from the street) from its corner `origin`, w inwards from the kerb.
struct BlockSide {
  Eigen::Vector2d origin, along, outward;
  double length = 0.0;
  double u_min = 0.0, u_max = 0.0;  ///< The part seen from the route (u_min > u_max: none).
  bool full_corners = true;         ///< The pavement strip covers the corner squares.
  Eigen::Vector2d at(double u, double w) const { return origin + u * along - w * outward; }
};

/// Buildings, gaps, street furniture and parked cars of one block side (city_blocks.cpp).
/// `texture_seed` is advanced for every texture made.
void buildBlockSide(Scene& scene, const CityGrid& grid, const BlockSide& side,
                    const std::vector<Eigen::Vector2d>& route, std::uint32_t& texture_seed);

}  // namespace scale_drift_slam::sim::detail
