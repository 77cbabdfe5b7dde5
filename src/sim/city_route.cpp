#include "city_route.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/core.hpp>

namespace scale_drift_slam::sim::detail {
namespace {

double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() * b.y() - a.y() * b.x();
}

}  // namespace

CityRoute::CityRoute(const std::vector<Eigen::Vector2d>& waypoints, const DriveParams& params,
                     unsigned seed)
    : acceleration_(params.acceleration) {
  if (waypoints.size() < 2) throw std::invalid_argument("a route needs two waypoints");
  cv::RNG rng(0xd41e0000ULL + seed);
  Eigen::Vector2d at = waypoints.front();
  double s = 0.0;
  auto add = [&](double length, double curvature, double speed, const Eigen::Vector2d& heading) {
    Piece piece;
    piece.s0 = s;
    piece.length = length;
    piece.curvature = curvature;
    piece.speed = speed;
    piece.start = at;
    piece.heading = heading;
    pieces_.push_back(piece);
    s += length;
  };
  double entry_cut = 0.0;  // what the previous corner's arc took off this segment's start
  for (size_t k = 0; k + 1 < waypoints.size(); ++k) {
    const Eigen::Vector2d d = (waypoints[k + 1] - waypoints[k]).normalized();
    const double segment = (waypoints[k + 1] - waypoints[k]).norm();
    double exit_cut = 0.0, angle = 0.0, radius = 0.0;
    Eigen::Vector2d next_d = d;
    if (k + 2 < waypoints.size()) {
      next_d = (waypoints[k + 2] - waypoints[k + 1]).normalized();
      angle = std::atan2(cross2(d, next_d), d.dot(next_d));
      radius = rng.uniform(params.turn_radius_min, params.turn_radius_max);
      exit_cut = std::abs(angle) > 1e-6 ? radius * std::tan(std::abs(angle) / 2) : 0.0;
    }
    const double straight = segment - entry_cut - exit_cut;
    if (straight < 0) throw std::invalid_argument("route segment too short for its turns");
    add(straight, 0.0, rng.uniform(params.cruise_speed_min, params.cruise_speed_max), d);
    at += straight * d;
    if (exit_cut > 0) {
      const double curvature = (angle > 0 ? 1.0 : -1.0) / radius;
      add(radius * std::abs(angle), curvature, params.turn_yaw_rate * radius, d);
      at = waypoints[k + 1] + exit_cut * next_d;
    }
    entry_cut = exit_cut;
  }
  length_ = s;
  // Time table: dt = ds / v by the midpoint rule.
  const int n = static_cast<int>(std::ceil(length_ / table_step_));
  table_step_ = length_ / n;
  times_.assign(static_cast<size_t>(n) + 1, 0.0);
  for (int i = 0; i < n; ++i)
    times_[i + 1] = times_[i] + table_step_ / speedAt((i + 0.5) * table_step_);
}

double CityRoute::speedAt(double s) const {
  // The fastest speed from which every piece's limit can still be met at the given deceleration
  // (and to which the car can have accelerated from every earlier limit).
  double v2 = 1e30;
  for (const Piece& p : pieces_) {
    const double distance = std::max({0.0, p.s0 - s, s - (p.s0 + p.length)});
    v2 = std::min(v2, p.speed * p.speed + 2.0 * acceleration_ * distance);
  }
  return std::sqrt(v2);
}

CityRoute::State CityRoute::atDistance(double s) const {
  s = std::clamp(s, 0.0, length_);
  auto it = std::upper_bound(pieces_.begin(), pieces_.end(), s,
                             [](double value, const Piece& p) { return value < p.s0; });
  const Piece& p = *std::prev(it == pieces_.begin() ? std::next(it) : it);
  const double u = std::min(s - p.s0, p.length);
  State state;
  state.speed = speedAt(s);
  state.curvature = p.curvature;
  if (p.curvature == 0.0) {
    state.position = p.start + u * p.heading;
    state.heading = p.heading;
    return state;
  }
  const double a = p.curvature * u;
  const Eigen::Vector2d left(-p.heading.y(), p.heading.x());
  state.position = p.start + (std::sin(a) * p.heading + (1.0 - std::cos(a)) * left) / p.curvature;
  state.heading = std::cos(a) * p.heading + std::sin(a) * left;
  return state;
}

CityRoute::State CityRoute::atTime(double t) const {
  t = std::clamp(t, 0.0, duration());
  const auto it = std::upper_bound(times_.begin(), times_.end(), t);
  const size_t i = std::min<size_t>(static_cast<size_t>(it - times_.begin()), times_.size() - 1);
  if (i == 0) return atDistance(0.0);
  const double f = (t - times_[i - 1]) / std::max(1e-12, times_[i] - times_[i - 1]);
  return atDistance((static_cast<double>(i - 1) + f) * table_step_);
}

}  // namespace scale_drift_slam::sim::detail
