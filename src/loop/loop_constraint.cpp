#include "scale_drift_slam/loop/loop_constraint.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "scale_drift_slam/common/statistics.h"

namespace scale_drift_slam::loop {

void LoopConstraintParams::validate() const {
  auto fail = [](const std::string& what) {
    throw std::invalid_argument("loop constraint: " + what);
  };
  if (!(ransac_threshold_px > 0.0)) fail("ransac_threshold_px must be > 0");
  if (ransac_iterations < 1) fail("ransac_iterations must be >= 1");
  if (!(ransac_confidence > 0.0 && ransac_confidence < 1.0)) {
    fail("ransac_confidence must be in (0, 1)");
  }
  if (min_inliers < 4) fail("min_inliers must be >= 4");
  if (!(min_inlier_ratio >= 0.0 && min_inlier_ratio <= 1.0)) {
    fail("min_inlier_ratio must be in [0, 1]");
  }
  if (min_scale_pairs < 1) fail("min_scale_pairs must be >= 1");
  refinement.validate();
}

namespace {

void validateInput(const LoopConstraintInput& input) {
  if (!(input.focal_length_px > 0.0) || !std::isfinite(input.focal_length_px)) {
    throw std::invalid_argument("loop constraint: focal length must be > 0");
  }
  for (const Match2D3D& m : input.matches) {
    if (!m.xy_current.allFinite() || !m.p_loop.allFinite()) {
      throw std::invalid_argument("loop constraint: a 2D-3D match is not finite");
    }
  }
  for (const Match3D3D& m : input.point_pairs) {
    if (!m.p_current.allFinite() || !m.p_loop.allFinite()) {
      throw std::invalid_argument("loop constraint: a 3D-3D pair is not finite");
    }
  }
}

}  // namespace

LoopConstraintResult estimateLoopPose(const LoopConstraintInput& input,
                                      const LoopConstraintParams& params,
                                      std::vector<bool>* inlier) {
  params.validate();
  validateInput(input);
  LoopConstraintResult result;
  LoopConstraint& c = result.constraint;
  c.current_id = input.current_id;
  c.loop_id = input.loop_id;
  c.num_matches = static_cast<int>(input.matches.size());
  if (c.num_matches < params.min_inliers) {
    result.reason = "only " + std::to_string(c.num_matches) + " 2D-3D matches";
    return result;
  }
  // P3P in RANSAC, then a robust refinement on all matches, the loop keyframe's frame playing
  // the world.
  features::MotionOnlyInput refine;
  refine.focal_length_px = input.focal_length_px;
  for (const Match2D3D& m : input.matches)
    refine.observations.push_back({m.p_loop, m.xy_current});
  std::vector<int> ransac_inliers;
  const std::optional<geometry::SE3> T_ransac =
      features::ransacPose(refine,
                           {params.ransac_threshold_px, params.ransac_iterations,
                            params.ransac_confidence, features::PnpSampleSolver::kP3P},
                           &ransac_inliers);
  if (!T_ransac) {
    result.reason = "P3P RANSAC found no pose";
    return result;
  }
  refine.T_cam_world_guess = *T_ransac;
  features::MotionOnlyBundleAdjustmentParams refine_params = params.refinement;
  refine_params.inlier_threshold_px = params.ransac_threshold_px;
  const features::MotionOnlyResult refined =
      features::solveMotionOnlyBundleAdjustment(refine, refine_params);
  c.T_current_loop = refined.T_cam_world;
  if (!c.T_current_loop.translation().allFinite() ||
      !c.T_current_loop.rotation().coeffs().allFinite()) {
    result.reason = "the refinement of the pose diverged";
    return result;
  }
  c.num_inliers = static_cast<int>(refined.statistics.num_inliers);
  c.rmse_px = refined.statistics.final_rmse_px;
  if (inlier) *inlier = refined.inlier;
  if (c.num_inliers < params.min_inliers ||
      c.num_inliers < params.min_inlier_ratio * c.num_matches) {
    result.reason = "only " + std::to_string(c.num_inliers) + " of " +
                    std::to_string(c.num_matches) + " 2D-3D matches are inliers";
    return result;
  }
  result.success = true;
  return result;
}

bool estimateLoopScale(const std::vector<Match3D3D>& pairs, const LoopConstraintParams& params,
                       LoopConstraint* constraint, std::string* reason) {
  std::vector<double> ratios;
  for (const Match3D3D& m : pairs) {
    const Eigen::Vector3d in_current = constraint->T_current_loop * m.p_loop;
    const double d_loop = in_current.norm(), d_current = m.p_current.norm();
    if (in_current.z() > 0.0 && m.p_current.z() > 0.0 && d_loop > 0.0 && d_current > 0.0) {
      ratios.push_back(d_current / d_loop);
    }
  }
  constraint->num_scale_pairs = static_cast<int>(ratios.size());
  if (constraint->num_scale_pairs < params.min_scale_pairs) {
    *reason = "only " + std::to_string(constraint->num_scale_pairs) + " usable 3D-3D pairs";
    return false;
  }
  constraint->scale = common::upperMedian(std::move(ratios));
  const geometry::SE3& T = constraint->T_current_loop;
  constraint->S_current_loop = geometry::Sim3::fromScale(
      T.rotation(), constraint->scale * T.translation(), constraint->scale);
  return true;
}

LoopConstraintResult estimateLoopConstraint(const LoopConstraintInput& input,
                                            const LoopConstraintParams& params) {
  LoopConstraintResult result = estimateLoopPose(input, params);
  if (!result.success) return result;
  result.success = estimateLoopScale(input.point_pairs, params, &result.constraint, &result.reason);
  return result;
}

}  // namespace scale_drift_slam::loop
