#pragma once
// Private to src/sim: a car's drive along a polyline of waypoints (the lane's centre, world x-y in
// metres): straights joined by circular arcs (a turn of radius R at every corner) and a speed that
// slows for the turns and speeds up on the straights with a bounded acceleration, as a driver does.

#include <vector>

#include <Eigen/Core>

namespace scale_drift_slam::sim::detail {

struct DriveParams {
  double turn_radius_min = 9.0;  ///< Per corner, drawn from [min, max] (metres).
  double turn_radius_max = 13.0;
  double cruise_speed_min = 9.5;  ///< Per straight, drawn from [min, max] (m/s).
  double cruise_speed_max = 13.0;
  double turn_yaw_rate = 0.5;  ///< rad/s in the turns (about 29 deg/s): the turn speed is rate * R.
  double acceleration = 1.6;   ///< m/s^2 braking before and accelerating after a turn.
};

class CityRoute {
 public:
  /// Where the car is: position, unit heading (x-y), speed (m/s) and signed curvature (1/m, left
  /// turns positive).
  struct State {
    Eigen::Vector2d position;
    Eigen::Vector2d heading;
    double speed = 0.0;
    double curvature = 0.0;
  };

  /// `waypoints`: at least two; radii and cruise speeds are drawn from `params` with `seed`.
  CityRoute(const std::vector<Eigen::Vector2d>& waypoints, const DriveParams& params,
            unsigned seed);

  double length() const { return length_; }
  double duration() const { return times_.back(); }
  /// The state at arc length s (clamped to [0, length]).
  State atDistance(double s) const;
  /// The state at time t (clamped to [0, duration]).
  State atTime(double t) const;

 private:
  struct Piece {  ///< A straight (curvature 0) or an arc from `start` with heading `heading`.
    double s0 = 0.0, length = 0.0, curvature = 0.0, speed = 0.0;
    Eigen::Vector2d start, heading;
  };
  double speedAt(double s) const;

  std::vector<Piece> pieces_;
  double length_ = 0.0;
  double acceleration_ = 1.6;
  double table_step_ = 0.05;   ///< Arc-length step of the time table.
  std::vector<double> times_;  ///< Time at s = k * table_step_.
};

}  // namespace scale_drift_slam::sim::detail
