#pragma once
// Metric verification of a place-recognition candidate (doc/algorithm.md, "Loop closure
// detection", steps 1-4), shared by loop closure and relocalisation:
//   1. the descriptor matches of the geometric check (current keypoint <-> candidate keypoint);
//   2. each matched candidate keypoint gets a depth by k-nearest-neighbour regression over the
//      candidate keyframe's projected map points (DepthRegressor): 2D-3D correspondences;
//   3. P3P RANSAC and a robust refinement give T_current_candidate; then every map point of the
//      candidate is searched in the current image with a perspectively warped patch cut from the
//      candidate's image (features::activeSearch) around its predicted pixel, and the pose is
//      refined again on all matches;
//   4. (loops only) the current keyframe's own map gives depths for its side of the matches:
//      3D-3D pairs, and the relative scale is their median distance ratio.
// A candidate that fails a test gets success = false and the reason. Pure functions; any thread.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "scale_drift_slam/features/active_search.h"
#include "scale_drift_slam/features/image_preparation.h"
#include "scale_drift_slam/geometry/camera_model.h"
#include "scale_drift_slam/loop/appearance.h"
#include "scale_drift_slam/loop/depth_regression.h"
#include "scale_drift_slam/loop/geometric_check.h"
#include "scale_drift_slam/loop/loop_constraint.h"
#include "scale_drift_slam/map/map.h"

namespace scale_drift_slam::loop {

struct LoopVerificationParams {
  DepthRegressionParams depth;
  LoopConstraintParams constraint;      ///< RANSAC, refinement and the minimum support.
  features::ActiveSearchParams search;  ///< The warped-patch search of the candidate's points.
  /// Prior uncertainty of T_current_candidate for the search regions: rotation (rad) and
  /// translation (fraction of the candidate's median scene depth).
  double search_rotation_sigma = 0.01;
  double search_translation_sigma = 0.02;
  int min_final_inliers = 40;  ///< 2D-3D inliers after the search and the second refinement.
  double max_rmse_px = 2.0;    ///< Of those inliers.
  double min_scale = 0.2;      ///< A relative scale outside [min_scale, max_scale] is refused
  double max_scale = 5.0;      ///< (a wrong depth association, not drift).
  /// Throws std::invalid_argument naming the first bad value.
  void validate() const;
};

/// What verification needs of one side (a keyframe, or a frame to relocalise): its ORB features
/// (undistorted pixels of the ideal pinhole, KeyframeAppearance::undistorted) and the map points
/// it observes, in its own camera frame, with their normalised image coordinates.
struct VerificationView {
  const KeyframeAppearance* features = nullptr;
  std::vector<map::PointId> point_ids;
  std::vector<Eigen::Vector2d> point_xy;      ///< Observed, undistorted normalised coordinates.
  std::vector<Eigen::Vector3d> point_camera;  ///< The point in this view's camera frame.
  /// The image the view was taken from (distorted, as captured): the candidate's patches are cut
  /// from it, the current view's image is searched. May be empty (no search then).
  features::ImagePyramid image;
};

/// A map point of the candidate found in the current image.
struct FoundPoint {
  map::PointId id = 0;
  Eigen::Vector2d px = Eigen::Vector2d::Zero();  ///< Raw (distorted) pixel in the current image.
  Eigen::Vector2d xy = Eigen::Vector2d::Zero();  ///< Undistorted normalised coordinates.
};

struct LoopVerification {
  bool success = false;
  std::string reason;  ///< The first test that failed; empty on success.
  /// T_current_loop, num_inliers, rmse_px always (as far as computed); scale, S_current_loop,
  /// num_scale_pairs for loops.
  LoopConstraint constraint;
  int descriptor_matches = 0;
  int matches_with_depth = 0;  ///< Of those, candidate keypoints that got a regressed depth.
  int ransac_inliers = 0;      ///< After the first refinement.
  int searched_points = 0;     ///< Candidate map points searched in the current image ...
  int found_points = 0;        ///< ... and found.
  std::vector<FoundPoint> inlier_points;  ///< Found points that are inliers of the final pose.
};

/// Steps 1-3: T_current_candidate. `matches`: query = current keypoint, candidate = keypoint of
/// the candidate view. Throws std::invalid_argument on invalid params or views.
LoopVerification verifyPose(const VerificationView& current, const VerificationView& candidate,
                            const std::vector<DescriptorMatch>& matches,
                            const geometry::CameraModel& camera,
                            const LoopVerificationParams& params);

/// Steps 1-4: the 7-DoF loop constraint S_current_candidate (ids set by the caller).
LoopVerification verifyLoop(const VerificationView& current, const VerificationView& candidate,
                            const std::vector<DescriptorMatch>& matches,
                            const geometry::CameraModel& camera,
                            const LoopVerificationParams& params);

}  // namespace scale_drift_slam::loop
