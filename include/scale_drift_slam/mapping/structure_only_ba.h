#pragma once
// Structure-only bundle adjustment (doc/algorithm.md, "Loop closure correction": "afterwards
// refine with structure-only BA"): the keyframe poses are held fixed and every point is refined
// alone, minimising the pseudo-Huber cost of its reprojection errors in pixels,
//   C(x) = sum_k rho(|F (pi(R_k x + t_k) - z_k)|^2),  rho(s) = 2 b^2 (sqrt(1 + s / b^2) - 1),
// F = diag(|fx|, |fy|), z_k the observation in normalised coordinates, pi(p) = (p_x, p_y) / p_z.
// (rho is ceres::SoftLOneLoss(b) on s = r^2; Ceres would minimise half of this sum.)
// Given the poses the points are independent, so each gets its own 3x3 Levenberg-Marquardt with
// iteratively reweighted normal equations (weights rho'(s)) instead of one large sparse problem.

#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/map/map.h"

namespace scale_drift_slam::mapping {

struct StructureOnlyBAOptions {
  int max_iterations = 10;           ///< Per point (the paper and its authors' code: ten).
  double huber_width_px = 1.0;       ///< b of the pseudo-Huber kernel (the authors' value).
  bool robust = true;                ///< false: plain least squares.
  double initial_damping = 1e-4;     ///< LM mu relative to the largest diagonal entry of H.
  double step_tolerance = 1e-10;     ///< Stop a point when |dx| < tol (|x| + tol) ...
  double function_tolerance = 1e-9;  ///< ... or its cost falls by less than this fraction.
  /// Cost of an observation whose point lies behind its camera (a residual of this many pixels).
  double behind_camera_residual_px = 1000.0;

  /// Throws std::invalid_argument naming the offending field.
  void validate() const;
};

/// Reprojection error statistics in pixels over the observations whose point is in front of the
/// camera; `behind` counts the others.
struct ReprojectionStats {
  std::size_t observations = 0;
  std::size_t behind = 0;
  double mean = 0.0;
  double rms = 0.0;
  double median = 0.0;
  double p90 = 0.0;
};

struct StructureOnlyBAResult {
  std::size_t points = 0;          ///< Points refined.
  std::size_t points_skipped = 0;  ///< Fewer than two observations in front of a camera.
  std::size_t observations = 0;
  int max_iterations_used = 0;  ///< The most LM iterations any point took.
  double mean_iterations = 0.0;
  double initial_cost = 0.0;  ///< sum of rho over all observations, pixels^2.
  double final_cost = 0.0;
  ReprojectionStats before;
  ReprojectionStats after;
  double time_s = 0.0;
};

/// The problem on plain arrays: fixed poses, the points to refine, and each point's observations
/// stored contiguously (point i owns observations[first_observation[i] .. first_observation[i+1])).
struct StructureOnlyProblem {
  struct Observation {
    std::size_t pose = 0;                          ///< Index into T_cam_world.
    Eigen::Vector2d xy = Eigen::Vector2d::Zero();  ///< Normalised image coordinates.
  };
  std::vector<geometry::SE3> T_cam_world;
  std::vector<Eigen::Vector3d> points;  ///< Refined in place.
  std::vector<Observation> observations;
  std::vector<std::size_t> first_observation;  ///< points.size() + 1 offsets.

  /// Throws std::invalid_argument when the offsets or pose indices are inconsistent.
  void validate() const;
};

/// Refines every point of `problem` (see the file comment). Throws std::invalid_argument for
/// invalid options or problem and a non-finite or zero focal length.
StructureOnlyBAResult refineStructure(StructureOnlyProblem& problem,
                                      const Eigen::Vector2d& focal_length_px,
                                      const StructureOnlyBAOptions& options);

/// The problem of `points` (all points of the map, in increasing id order, when empty) with all
/// their observations in the map, poses in the map's keyframe order. Throws std::out_of_range
/// for an unknown point id and std::invalid_argument for a point listed twice.
StructureOnlyProblem makeStructureOnlyProblem(const map::Map& map,
                                              const std::vector<map::PointId>& points);

/// Refines the positions of `points` (all points of the map when empty) against all their
/// observations in the map; poses are fixed. `focal_length_px` = (fx, fy) turns normalised
/// residuals into pixels (signs do not matter). Throws std::invalid_argument for invalid options,
/// a non-finite / zero focal length, std::out_of_range for an unknown point id. Bumps the map
/// version.
StructureOnlyBAResult refineStructure(map::Map& map, const std::vector<map::PointId>& points,
                                      const Eigen::Vector2d& focal_length_px,
                                      const StructureOnlyBAOptions& options);

/// Reprojection errors (pixels) of all observations in the map.
ReprojectionStats reprojectionStats(const map::Map& map, const Eigen::Vector2d& focal_length_px);

}  // namespace scale_drift_slam::mapping
