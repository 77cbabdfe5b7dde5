#include "scale_drift_slam/tracking/keyframe_rule.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "scale_drift_slam/common/statistics.h"

namespace scale_drift_slam::tracking {

void KeyframeRuleParams::validate() const {
  if (!(distance_to_depth_ratio > 0.0) || !std::isfinite(distance_to_depth_ratio)) {
    throw std::invalid_argument("keyframe rule: distance_to_depth_ratio must be > 0");
  }
  if (!(min_tracked_ratio >= 0.0 && min_tracked_ratio < 1.0)) {
    throw std::invalid_argument("keyframe rule: min_tracked_ratio must be in [0, 1)");
  }
  if (min_tracked_points < 0) {
    throw std::invalid_argument("keyframe rule: min_tracked_points must be >= 0");
  }
  if (!(min_distance_fraction >= 0.0 && min_distance_fraction <= 1.0)) {
    throw std::invalid_argument("keyframe rule: min_distance_fraction must be in [0, 1]");
  }
  if (min_certain_candidates < 0) {
    throw std::invalid_argument("keyframe rule: min_certain_candidates must be >= 0");
  }
  if (!(max_view_turn_fraction >= 0.0) || !std::isfinite(max_view_turn_fraction)) {
    throw std::invalid_argument("keyframe rule: max_view_turn_fraction must be >= 0");
  }
}

double medianSceneDepth(const geometry::SE3& T_cam_world,
                        const std::vector<Eigen::Vector3d>& points_world) {
  std::vector<double> depths;
  depths.reserve(points_world.size());
  for (const Eigen::Vector3d& p : points_world) {
    const double z = (T_cam_world * p).z();
    if (z > 0.0 && std::isfinite(z)) depths.push_back(z);
  }
  if (depths.empty()) {
    throw std::invalid_argument("scene depth: no point lies in front of the camera");
  }
  return common::upperMedian(std::move(depths));
}

KeyframeDecision decideKeyframe(
    const Eigen::Vector3d& camera_centre_world,
    const std::vector<std::pair<map::KeyframeId, Eigen::Vector3d>>& keyframe_centres,
    double scene_depth, const KeyframeRuleParams& params,
    const std::optional<TrackedPoints>& tracked, const std::optional<ViewDirections>& view) {
  params.validate();
  if (!(scene_depth > 0.0) || !std::isfinite(scene_depth)) {
    throw std::invalid_argument("keyframe rule: the scene depth must be positive and finite");
  }
  KeyframeDecision decision;
  decision.threshold = params.distance_to_depth_ratio * scene_depth;
  decision.distance = std::numeric_limits<double>::infinity();
  for (const auto& [id, centre] : keyframe_centres) {
    const double d = (centre - camera_centre_world).norm();
    if (d < decision.distance) {
      decision.distance = d;
      decision.closest = id;
    }
  }
  decision.drop = decision.distance > decision.threshold;
  // Parallax for new points: the camera moved, or the new features' filters measured it (their
  // depths are certain, at a fast pan after a few frames, long before the distance is reached).
  const bool parallax = decision.distance > params.min_distance_fraction * decision.threshold ||
                        (tracked && params.min_certain_candidates > 0 &&
                         tracked->certain_candidates >= params.min_certain_candidates);
  if (!decision.drop && tracked && tracked->at_last_keyframe > 0) {
    // At an open crossing the near facades leave the view, the median depth of what is left
    // doubles and so does the distance threshold, just when new points are needed most.
    const bool starving = tracked->now < params.min_tracked_points;
    decision.view_leaving_map =
        (tracked->now < params.min_tracked_ratio * tracked->at_last_keyframe || starving) &&
        parallax;
    decision.drop = decision.view_leaving_map;
  }
  if (!decision.drop && view && params.max_view_turn_fraction > 0.0 && parallax) {
    if (view->keyframes.size() != keyframe_centres.size()) {
      throw std::invalid_argument("keyframe rule: one viewing direction per keyframe expected");
    }
    // A nearby keyframe looking elsewhere does not cover this view: when the camera pans, the
    // map points leave the image within a few frames, and new ones are spawned and promoted only
    // at keyframes (the baseline condition keeps a camera turning on the spot from dropping any).
    const double max_turn = params.max_view_turn_fraction * view->field_of_view;
    bool covered = false;
    for (std::size_t k = 0; k < keyframe_centres.size() && !covered; ++k) {
      if ((keyframe_centres[k].second - camera_centre_world).norm() > decision.threshold) continue;
      const double cos_turn = std::clamp(view->keyframes[k].dot(view->current), -1.0, 1.0);
      covered = std::acos(cos_turn) <= max_turn;
    }
    decision.view_turned = !covered;
    decision.drop = decision.view_turned;
  }
  return decision;
}

}  // namespace scale_drift_slam::tracking
