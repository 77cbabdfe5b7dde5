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
  if (!(min_distance_fraction >= 0.0 && min_distance_fraction <= 1.0)) {
    throw std::invalid_argument("keyframe rule: min_distance_fraction must be in [0, 1]");
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
    const std::optional<TrackedPoints>& tracked) {
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
  if (!decision.drop && tracked && tracked->at_last_keyframe > 0) {
    decision.view_leaving_map =
        tracked->now < params.min_tracked_ratio * tracked->at_last_keyframe &&
        decision.distance > params.min_distance_fraction * decision.threshold;
    decision.drop = decision.view_leaving_map;
  }
  return decision;
}

}  // namespace scale_drift_slam::tracking
