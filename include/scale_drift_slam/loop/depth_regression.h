#pragma once
// Depths for image features that are not map points (doc/algorithm.md, "Loop closure
// detection", step 2): the map points a keyframe observes give a sparse depth map of the surface
// it sees; the depth at another image location is regressed from its k nearest projected points
// (a locally linear fit of inverse depth, weighted by inverse distance: exact on a plane; the
// weighted mean where the neighbours are collinear), and refused where the neighbours disagree (a
// depth discontinuity: the feature may lie on either side) or are too far away. Plain data; any
// thread.

#include <optional>
#include <vector>

#include <Eigen/Core>

namespace scale_drift_slam::loop {

struct DepthRegressionParams {
  int k = 5;                          ///< Neighbours used.
  int min_neighbours = 3;             ///< Fewer within max_distance_px: no depth.
  double max_distance_px = 40.0;      ///< Neighbours farther than this are not used.
  double max_relative_spread = 0.15;  ///< (max - min) / median depth of the neighbours.
  /// Throws std::invalid_argument naming the first bad value.
  void validate() const;
};

class DepthRegressor {
 public:
  /// `xy`: normalised image coordinates of the projected points, `depths`: their depths (z in the
  /// camera frame, > 0; others are skipped). `focal_length_px` converts distances to pixels.
  /// Throws std::invalid_argument on different sizes or invalid params.
  DepthRegressor(const std::vector<Eigen::Vector2d>& xy, const std::vector<double>& depths,
                 double focal_length_px, const DepthRegressionParams& params);

  /// The regressed depth at normalised `xy`, or nullopt (too few neighbours, or they disagree).
  std::optional<double> depthAt(const Eigen::Vector2d& xy) const;
  /// depthAt(xy) * (x, y, 1): the 3D point in the camera frame.
  std::optional<Eigen::Vector3d> pointAt(const Eigen::Vector2d& xy) const;
  std::size_t size() const { return xy_.size(); }

 private:
  std::vector<Eigen::Vector2d> xy_;
  std::vector<double> depths_;
  double max_distance_sq_;  ///< In normalised units squared.
  DepthRegressionParams params_;
};

}  // namespace scale_drift_slam::loop
