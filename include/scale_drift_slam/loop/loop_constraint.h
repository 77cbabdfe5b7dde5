#pragma once
// The 7-DoF loop constraint between the current keyframe c and a loop keyframe l
// (doc/algorithm.md, "Loop closure detection", steps 3 and 4):
//   - 6 DoF from 2D-3D correspondences (features of c, points of l's map in l's camera frame):
//     P3P inside RANSAC (OpenCV solvePnPRansac with SOLVEPNP_AP3P: 3 points plus a 4th to choose
//     among the solutions, i.e. the paper's P4P), then a robust refinement (motion-only BA,
//     pseudo-Huber) on all matches;
//   - the scale from 3D-3D correspondences (a point's position in c's frame from the current map,
//     and in l's frame from the loop map) as the median of the distance ratios
//     s_k = |p_k^c| / |T_cl p_k^l| (distances from the current camera centre).
// Result: S_current_loop = [s R, s t; 0 1] with (R, t) = T_cl, so x_c = S_current_loop x_l maps
// loop-keyframe coordinates into current-keyframe coordinates, each in its own map's scale. This
// is the edge measurement S_cl = S_c S_l^-1 of the Sim(3) pose graph. Pure function; any thread.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "scale_drift_slam/features/motion_only_bundle_adjustment.h"
#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/geometry/sim3.h"
#include "scale_drift_slam/map/map.h"

namespace scale_drift_slam::loop {

struct LoopConstraintParams {
  double ransac_threshold_px = 3.0;  ///< Inlier threshold of RANSAC and of the refinement.
  int ransac_iterations = 200;
  double ransac_confidence = 0.999;
  int min_inliers = 12;           ///< Fewer 2D-3D inliers: no constraint.
  double min_inlier_ratio = 0.3;  ///< Of the 2D-3D matches.
  int min_scale_pairs = 5;        ///< Fewer usable 3D-3D pairs: no constraint.
  features::MotionOnlyBundleAdjustmentParams refinement;  ///< Its thresholds in pixels too.
  /// Throws std::invalid_argument naming the first bad value.
  void validate() const;
};

/// A feature of the current keyframe (normalised coordinates) matched to a point of the loop
/// keyframe's map, expressed in the loop keyframe's camera frame.
struct Match2D3D {
  Eigen::Vector2d xy_current = Eigen::Vector2d::Zero();
  Eigen::Vector3d p_loop = Eigen::Vector3d::Zero();
};

/// One physical point in both maps: in the current keyframe's frame and in the loop keyframe's.
struct Match3D3D {
  Eigen::Vector3d p_current = Eigen::Vector3d::Zero();
  Eigen::Vector3d p_loop = Eigen::Vector3d::Zero();
};

struct LoopConstraintInput {
  map::KeyframeId current_id = 0;
  map::KeyframeId loop_id = 0;
  std::vector<Match2D3D> matches;
  std::vector<Match3D3D> point_pairs;
  double focal_length_px = 0.0;
};

struct LoopConstraint {
  map::KeyframeId current_id = 0;
  map::KeyframeId loop_id = 0;
  geometry::Sim3 S_current_loop;  ///< Maps loop-keyframe coordinates into the current keyframe's.
  geometry::SE3 T_current_loop;   ///< The rigid part, in the loop map's scale.
  double scale = 1.0;             ///< s: current map units per loop map unit.
  int num_matches = 0;
  int num_inliers = 0;      ///< 2D-3D inliers after refinement.
  int num_scale_pairs = 0;  ///< 3D-3D pairs that entered the median.
  double rmse_px = 0.0;     ///< Of the 2D-3D inliers.
};

struct LoopConstraintResult {
  bool success = false;
  std::string reason;  ///< Why there is no constraint (empty on success).
  LoopConstraint constraint;
};

/// Estimates the constraint: estimateLoopPose, then estimateLoopScale. Bad input (non-finite
/// values, focal length <= 0) throws std::invalid_argument; too little support gives
/// success = false with the reason.
LoopConstraintResult estimateLoopConstraint(const LoopConstraintInput& input,
                                            const LoopConstraintParams& params);

/// The 6-DoF part alone (input.point_pairs unused): P3P RANSAC and the robust refinement. On
/// success constraint.T_current_loop, num_matches, num_inliers and rmse_px are set; `inlier`
/// (optional) receives one flag per match.
LoopConstraintResult estimateLoopPose(const LoopConstraintInput& input,
                                      const LoopConstraintParams& params,
                                      std::vector<bool>* inlier = nullptr);

/// The scale part: the median of |p^c| / |T_cl p^l| over the pairs in front of both cameras.
/// Fills scale, S_current_loop and num_scale_pairs of `constraint` (T_current_loop must be set);
/// returns false with `reason` when fewer than min_scale_pairs pairs are usable.
bool estimateLoopScale(const std::vector<Match3D3D>& pairs, const LoopConstraintParams& params,
                       LoopConstraint* constraint, std::string* reason);

}  // namespace scale_drift_slam::loop
