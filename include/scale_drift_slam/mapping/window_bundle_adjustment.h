#pragma once
// Sliding-window bundle adjustment (doc/algorithm.md, "Back-end: sliding-window bundle
// adjustment"): minimise sum rho(|f (z_ij - proj(T_i x_j))|) over the poses of the newest N
// keyframes (paper: N = 10) and the points they see, with the two oldest window keyframes fixed
// (they anchor rotation, translation and scale: the 7-DoF gauge), the pseudo-Huber kernel rho and
// Ceres' SPARSE_SCHUR (points eliminated, sparse Cholesky by SuiteSparse on the reduced camera
// system).
//
// The solver works on a copied snapshot (WindowBundleInput) and returns a WindowBundleResult: the
// mapping thread can optimise while tracking goes on, and the owner of the map applies the result
// by map version (applyWindowResult). Nothing here touches global state.

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "scale_drift_slam/features/bundle_statistics.h"
#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/map/map.h"

namespace scale_drift_slam::mapping {

struct WindowBundleAdjustmentParams {
  int window_size = 10;              ///< Newest keyframes in the window (paper: 10).
  int num_fixed_keyframes = 2;       ///< Oldest window keyframes held fixed (>= 2: 7-DoF gauge).
  double huber_width_px = 2.0;       ///< b of the pseudo-Huber kernel, in pixels.
  double inlier_threshold_px = 3.0;  ///< Observations with a larger final error are outliers.
  int max_iterations = 10;           ///< Levenberg-Marquardt iterations.
  /// Relative cost decrease that counts as converged. 1e-4 of the cost is ~0.005% of the RMS
  /// error: the sliding window is re-optimised at every keyframe anyway (doc/backend.md).
  double function_tolerance = 1e-4;
  int num_threads = 1;
  /// Throws std::invalid_argument naming the first bad value.
  void validate() const;
};

/// A keyframe pose in a bundle adjustment problem (also used by other BA-like estimators).
struct BundleKeyframe {
  map::KeyframeId id = 0;
  geometry::SE3 T_kf_world;
  bool fixed = false;
};

struct BundlePoint {
  map::PointId id = 0;
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
  bool fixed = false;  ///< Held constant (e.g. seen by only one window keyframe).
};

/// An observation in undistorted normalised coordinates; indices into the input's vectors.
struct BundleObservation {
  std::size_t keyframe_index = 0;
  std::size_t point_index = 0;
  Eigen::Vector2d xy = Eigen::Vector2d::Zero();
};

/// A self-contained copy of the window: poses, points, observations.
struct WindowBundleInput {
  std::vector<BundleKeyframe> keyframes;
  std::vector<BundlePoint> points;
  std::vector<BundleObservation> observations;
  double focal_length_px = 0.0;  ///< Scales normalised residuals to pixels.
  /// Throws std::invalid_argument for bad indices, a non-positive focal length, non-finite values.
  void validate() const;
};

struct WindowBundleResult {
  std::vector<BundleKeyframe> keyframes;  ///< Same order as the input; fixed ones unchanged.
  std::vector<BundlePoint> points;        ///< Same order as the input.
  std::vector<bool> inlier;               ///< Per input observation.
  features::BundleStatistics statistics;
};

/// Builds the window from the map: the newest `window_size` keyframes (by id), the two
/// (`num_fixed_keyframes`) oldest of them fixed, every point a free window keyframe observes, and
/// their observations. Points seen by fewer than two window keyframes are included but fixed (they
/// still constrain the poses); points seen only by the fixed keyframes are left out (they
/// constrain no free pose, and re-triangulating them from the fixed pair alone would discard what
/// their older observations told). Throws std::invalid_argument when the map has fewer keyframes
/// than `num_fixed_keyframes` + 1.
WindowBundleInput makeWindowInput(const map::Map& map, const WindowBundleAdjustmentParams& params,
                                  double focal_length_px);

/// Runs the optimisation. Observations whose point is not in front of its camera at the start
/// are left out (and reported as outliers). Throws std::invalid_argument for invalid input.
WindowBundleResult solveWindowBundleAdjustment(const WindowBundleInput& input,
                                               const WindowBundleAdjustmentParams& params);

/// Writes the optimised poses and points into the map (those no longer in the map are skipped)
/// and bumps its version. Returns the number of entities written.
std::size_t applyWindowResult(const WindowBundleResult& result, map::Map& map);

}  // namespace scale_drift_slam::mapping
