#pragma once
// Map initialisation from two views (doc/algorithm.md, "Front-end"; the paper leaves the
// method open): fit a homography and an essential
// matrix to the correspondences (OpenCV RANSAC), select one by Torr's GRIC (which weighs the fit
// against the model's complexity; ORB-SLAM's score ratio favours the 5-point essential matrix even
// on planes), decompose the chosen model into its motion hypotheses, triangulate under each and
// keep the one whose points pass cheirality, reprojection and parallax checks. When others come
// close (a homography's two-fold ambiguity), each is refined by two-view BA and the one with
// clearly lower reprojection errors on the points off the plane wins (doc/frontend.md).
// Two-view bundle adjustment follows, then the scale is normalised so that the median depth in
// the first view is 1. Pure rotation has no parallax and is refused.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "scale_drift_slam/geometry/se3.h"

namespace scale_drift_slam::tracking {

struct TwoViewParams {
  double ransac_threshold_px = 2.0;      ///< RANSAC inlier threshold of both models (pixels).
  double sigma_px = 1.0;                 ///< Image noise for the model scores (pixels).
  double max_reprojection_px = 3.0;      ///< A triangulated point must reproject within this.
  double min_point_parallax_deg = 0.3;   ///< Points with less parallax are not triangulated.
  double min_median_parallax_deg = 1.0;  ///< Refuse when the median parallax is below this.
  int min_points = 50;                   ///< Refuse with fewer good points.
  double min_good_fraction = 0.5;        ///< ...or with fewer than this fraction of the inliers.
  double ambiguity_ratio = 0.7;          ///< Contenders: motions keeping >= this * best's points.
  /// Among contenders, the winner must explain this many standard deviations (of a fair split)
  /// more of the points that tell them apart than each other contender does; else refuse.
  double ambiguity_sigmas = 3.0;
  /// Refuse when the rotation's standard deviation (depths marginalised, sigma_px per point)
  /// exceeds this share of the median parallax: rotation and translation across the view are
  /// then barely told apart (a small baseline through a narrow lens), the wrong mix fits as well.
  double max_rotation_sigma_ratio = 0.1;
  int bundle_adjustment_iterations = 20;
  void validate() const;
};

struct TwoViewResult {
  bool success = false;
  std::string reason;  ///< Why it was refused ("" on success).
  bool used_homography = false;
  bool ambiguity_resolved = false;  ///< Contending motions were told apart (resolveAmbiguity).
  double gric_homography = 0.0;     ///< GRIC of both models (lower is better).
  double gric_essential = 0.0;
  double median_parallax_deg = 0.0;
  /// Standard deviation of the rotation (degrees, worst axis) with the depths marginalised.
  double rotation_sigma_deg = 0.0;
  geometry::SE3 T_second_first;  ///< Maps first-camera points into the second camera.
  /// Per correspondence: its point in the first camera frame (valid where `triangulated`).
  std::vector<Eigen::Vector3d> points_first;
  std::vector<bool> triangulated;
  int num_triangulated = 0;
};

/// Reconstructs two views from correspondences in undistorted normalised coordinates (z = 1).
/// `focal_px` converts the pixel thresholds. Never throws on degenerate input: the result says
/// why it failed.
TwoViewResult reconstructTwoView(const std::vector<Eigen::Vector2d>& xy_first,
                                 const std::vector<Eigen::Vector2d>& xy_second, double focal_px,
                                 const TwoViewParams& params);

/// Linear (DLT) triangulation of one point seen at normalised xy_first in camera [I|0] and at
/// xy_second in T_second_first. Returns the point in the first camera frame.
Eigen::Vector3d triangulateTwoView(const Eigen::Vector2d& xy_first,
                                   const Eigen::Vector2d& xy_second,
                                   const geometry::SE3& T_second_first);

/// The parallax angle (degrees) between the two rays that meet at p_first.
double parallaxDeg(const Eigen::Vector3d& p_first, const geometry::SE3& T_second_first);

/// Two-view bundle adjustment (Ceres, features::ReprojectionCost, pseudo-Huber with b = huber_px
/// pixels): refines the second pose and the points marked in `use`, the first camera fixed at the
/// identity and the baseline |t| kept at its value (the scale gauge: the solution is scaled back
/// to it). Residuals are normalised-coordinate errors times `focal_px`.
void bundleAdjustTwoView(const std::vector<Eigen::Vector2d>& xy_first,
                         const std::vector<Eigen::Vector2d>& xy_second,
                         const std::vector<bool>& use, double focal_px, double huber_px,
                         int max_iterations, geometry::SE3* T_second_first,
                         std::vector<Eigen::Vector3d>* points_first);

}  // namespace scale_drift_slam::tracking
