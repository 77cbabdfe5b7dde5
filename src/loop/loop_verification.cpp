#include "scale_drift_slam/loop/loop_verification.h"

#include <cmath>
#include <stdexcept>

#include "scale_drift_slam/common/statistics.h"
#include "scale_drift_slam/features/feature_detection.h"

namespace scale_drift_slam::loop {

void LoopVerificationParams::validate() const {
  auto fail = [](const std::string& what) {
    throw std::invalid_argument("loop verification: " + what);
  };
  depth.validate();
  constraint.validate();
  search.validate();
  if (!(search_rotation_sigma > 0.0) || !(search_translation_sigma > 0.0)) {
    fail("search_rotation_sigma and search_translation_sigma must be > 0");
  }
  if (min_final_inliers < constraint.min_inliers) {
    fail("min_final_inliers must be >= constraint.min_inliers");
  }
  if (!(max_rmse_px > 0.0)) fail("max_rmse_px must be > 0");
  if (!(min_scale > 0.0 && min_scale < 1.0 && max_scale > 1.0)) {
    fail("need 0 < min_scale < 1 < max_scale");
  }
}

namespace {

/// Normalised coordinates of an undistorted keypoint (ideal pinhole with the camera's K).
Eigen::Vector2d normalised(const cv::Point2f& px, const geometry::CameraCalibration& c) {
  return {(px.x - c.cx) / c.fx, (px.y - c.cy) / c.fy};
}

DepthRegressor regressorOf(const VerificationView& view, double focal,
                           const DepthRegressionParams& params) {
  std::vector<double> depths;
  depths.reserve(view.point_camera.size());
  for (const Eigen::Vector3d& p : view.point_camera)
    depths.push_back(p.z());
  return DepthRegressor(view.point_xy, depths, focal, params);
}

void validateView(const VerificationView& view, const char* name) {
  if (!view.features) {
    throw std::invalid_argument(std::string("loop verification: the ") + name +
                                " view has no features");
  }
  if (view.point_ids.size() != view.point_xy.size() ||
      view.point_ids.size() != view.point_camera.size()) {
    throw std::invalid_argument(std::string("loop verification: the ") + name +
                                " view's point arrays differ in size");
  }
}

/// The pose part with everything verifyLoop needs afterwards.
struct PoseSolution {
  LoopVerification verification;
  LoopConstraintInput input;  ///< The final 2D-3D matches.
  std::vector<bool> inlier;   ///< Per final match.
};

/// Steps 1-2: the descriptor matches whose candidate keypoint gets a depth from the candidate's
/// map points (regressed), as 2D-3D matches. Throws when a match names a missing keypoint.
LoopConstraintInput matchesWithDepth(const VerificationView& current,
                                     const VerificationView& candidate,
                                     const std::vector<DescriptorMatch>& matches,
                                     const geometry::CameraCalibration& calibration,
                                     const DepthRegressionParams& params) {
  LoopConstraintInput input;
  input.focal_length_px = calibration.meanFocalLength();
  const DepthRegressor candidate_depths = regressorOf(candidate, input.focal_length_px, params);
  for (const DescriptorMatch& m : matches) {
    if (m.query < 0 || m.candidate < 0 ||
        static_cast<std::size_t>(m.query) >= current.features->size() ||
        static_cast<std::size_t>(m.candidate) >= candidate.features->size()) {
      throw std::invalid_argument("loop verification: a match names a keypoint that is not there");
    }
    const Eigen::Vector2d xy_candidate =
        normalised(candidate.features->keypoints[m.candidate], calibration);
    const std::optional<Eigen::Vector3d> p_candidate = candidate_depths.pointAt(xy_candidate);
    if (!p_candidate) continue;
    input.matches.push_back(
        {normalised(current.features->keypoints[m.query], calibration), *p_candidate});
  }
  return input;
}

/// A candidate map point found in the current image by the patch search.
struct FoundPoint {
  std::size_t candidate_index = 0;  ///< Into the candidate view's point arrays.
  features::SearchMatch match;
};

struct CandidateSearch {
  std::vector<FoundPoint> found;
  int searched = 0;  ///< Points whose patch was matched against the current image.
};

/// Step 3b: the candidate's map points searched in the current image around T_current_loop.
CandidateSearch searchCandidatePoints(const VerificationView& current,
                                      const VerificationView& candidate,
                                      const geometry::SE3& T_current_loop,
                                      const geometry::CameraModel& camera,
                                      const LoopVerificationParams& params) {
  std::vector<features::PointAppearance> patches;
  patches.reserve(candidate.point_ids.size());
  std::vector<features::SearchPoint> points;
  std::vector<std::size_t> point_index;  // into the candidate view, per search point
  std::vector<double> depths;
  for (std::size_t i = 0; i < candidate.point_ids.size(); ++i) {
    const std::optional<Eigen::Vector2d> px = camera.project(candidate.point_camera[i]);
    features::PointAppearance patch;
    if (!px || !patch.cut(candidate.image, *px)) continue;
    patches.push_back(std::move(patch));
    points.push_back({candidate.point_camera[i], geometry::SE3(), &patches.back()});
    point_index.push_back(i);
    depths.push_back(candidate.point_camera[i].z());
  }
  CandidateSearch search;
  if (points.empty()) return search;
  const double translation_sigma =
      params.search_translation_sigma * common::upperMedian(std::move(depths));
  Eigen::Matrix<double, 6, 6> Sigma = Eigen::Matrix<double, 6, 6>::Zero();
  Sigma.diagonal().head<3>().setConstant(params.search_rotation_sigma *
                                         params.search_rotation_sigma);
  Sigma.diagonal().tail<3>().setConstant(translation_sigma * translation_sigma);
  const features::CornerGrid corners = features::detectSearchCorners(current.image, params.search);
  const std::vector<features::SearchMatch> matches = features::activeSearch(
      points, T_current_loop, Sigma, camera, current.image, corners, params.search);
  for (std::size_t k = 0; k < matches.size(); ++k) {
    search.searched += matches[k].searched;
    if (matches[k].found) search.found.push_back({point_index[k], matches[k]});
  }
  return search;
}

PoseSolution solvePose(const VerificationView& current, const VerificationView& candidate,
                       const std::vector<DescriptorMatch>& matches,
                       const geometry::CameraModel& camera, const LoopVerificationParams& params) {
  params.validate();
  validateView(current, "current");
  validateView(candidate, "candidate");
  PoseSolution solution;
  LoopVerification& v = solution.verification;
  v.descriptor_matches = static_cast<int>(matches.size());

  // Steps 1-2: descriptor matches with a regressed depth on the candidate side.
  LoopConstraintInput& input = solution.input;
  input = matchesWithDepth(current, candidate, matches, camera.calibration(), params.depth);
  v.matches_with_depth = static_cast<int>(input.matches.size());

  // Step 3: P3P RANSAC and refinement on them.
  const LoopConstraintResult first = estimateLoopPose(input, params.constraint);
  v.constraint = first.constraint;
  v.ransac_inliers = first.constraint.num_inliers;
  if (!first.success) {
    v.reason = "descriptor matches: " + first.reason;
    return solution;
  }

  // Step 3b: more matches by warped-patch search, then the final refinement on all of them.
  CandidateSearch search;
  if (!current.image.levels.empty() && !candidate.image.levels.empty()) {
    search =
        searchCandidatePoints(current, candidate, first.constraint.T_current_loop, camera, params);
  }
  v.searched_points = search.searched;
  v.found_points = static_cast<int>(search.found.size());
  const std::size_t num_descriptor_matches = input.matches.size();
  for (const FoundPoint& point : search.found)
    input.matches.push_back({point.match.xy, candidate.point_camera[point.candidate_index]});
  const LoopConstraintResult final_pose =
      estimateLoopPose(input, params.constraint, &solution.inlier);
  v.constraint = final_pose.constraint;
  if (!final_pose.success) {
    v.reason = "after the patch search: " + final_pose.reason;
    return solution;
  }
  for (std::size_t j = 0; j < search.found.size(); ++j) {
    if (!solution.inlier[num_descriptor_matches + j]) continue;
    const FoundPoint& point = search.found[j];
    v.inlier_points.push_back(
        {candidate.point_ids[point.candidate_index], point.match.px, point.match.xy});
  }
  if (v.constraint.num_inliers < params.min_final_inliers) {
    v.reason = "only " + std::to_string(v.constraint.num_inliers) + " inliers (at least " +
               std::to_string(params.min_final_inliers) + " needed)";
    return solution;
  }
  if (v.constraint.rmse_px > params.max_rmse_px) {
    v.reason = "inlier RMSE " + std::to_string(v.constraint.rmse_px) + " px";
    return solution;
  }
  v.success = true;
  return solution;
}

}  // namespace

LoopVerification verifyPose(const VerificationView& current, const VerificationView& candidate,
                            const std::vector<DescriptorMatch>& matches,
                            const geometry::CameraModel& camera,
                            const LoopVerificationParams& params) {
  return solvePose(current, candidate, matches, camera, params).verification;
}

LoopVerification verifyLoop(const VerificationView& current, const VerificationView& candidate,
                            const std::vector<DescriptorMatch>& matches,
                            const geometry::CameraModel& camera,
                            const LoopVerificationParams& params) {
  PoseSolution solution = solvePose(current, candidate, matches, camera, params);
  LoopVerification& v = solution.verification;
  if (!v.success) return v;
  // Step 4: the current keyframe's own depths for the inlier matches: 3D-3D pairs.
  const geometry::CameraCalibration& calibration = camera.calibration();
  const double focal = calibration.meanFocalLength();
  const DepthRegressor current_depths = regressorOf(current, focal, params.depth);
  std::vector<Match3D3D> pairs;
  for (std::size_t i = 0; i < solution.input.matches.size(); ++i) {
    if (!solution.inlier[i]) continue;
    const Match2D3D& m = solution.input.matches[i];
    if (const std::optional<Eigen::Vector3d> p_current = current_depths.pointAt(m.xy_current)) {
      pairs.push_back({*p_current, m.p_loop});
    }
  }
  std::string reason;
  if (!estimateLoopScale(pairs, params.constraint, &v.constraint, &reason)) {
    v.success = false;
    v.reason = "scale: " + reason;
    return v;
  }
  if (v.constraint.scale < params.min_scale || v.constraint.scale > params.max_scale) {
    v.success = false;
    v.reason = "relative scale " + std::to_string(v.constraint.scale) + " outside [" +
               std::to_string(params.min_scale) + ", " + std::to_string(params.max_scale) + "]";
  }
  return v;
}

}  // namespace scale_drift_slam::loop
