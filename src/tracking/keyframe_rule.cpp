#include "scale_drift_slam/tracking/keyframe_rule.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
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
  if (!(max_distance_to_depth_ratio == 0.0 ||
        max_distance_to_depth_ratio >= distance_to_depth_ratio) ||
      !std::isfinite(max_distance_to_depth_ratio)) {
    throw std::invalid_argument(
        "keyframe rule: max_distance_to_depth_ratio must be 0 or >= distance_to_depth_ratio");
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

double medianParallax(const std::vector<Eigen::Vector3d>& points_world, const Eigen::Vector3d& from,
                      const Eigen::Vector3d& to) {
  std::vector<double> angles;
  angles.reserve(points_world.size());
  for (const Eigen::Vector3d& p : points_world) {
    const Eigen::Vector3d a = p - from;
    const Eigen::Vector3d b = p - to;
    const double angle = std::atan2(a.cross(b).norm(), a.dot(b));
    if (std::isfinite(angle)) angles.push_back(angle);
  }
  if (angles.empty()) return std::numeric_limits<double>::quiet_NaN();
  return common::upperMedian(std::move(angles));
}

std::string keyframeReason(const KeyframeDecision& decision) {
  if (decision.view_leaving_map) return "keyframe: view leaving the map";
  if (decision.view_turned) return "keyframe: view turned";
  char text[128];
  if (std::isnan(decision.parallax)) {
    std::snprintf(text, sizeof(text), "keyframe: moved %.3g (threshold %.3g)", decision.distance,
                  decision.threshold);
  } else {
    std::snprintf(text, sizeof(text), "keyframe: moved %.3g (threshold %.3g), parallax %.2f deg",
                  decision.distance, decision.threshold, decision.parallax * 180.0 / M_PI);
  }
  return text;
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
  // Keyframes within this distance cover the view (the view-turn rule below).
  double reach = decision.threshold;
  if (decision.drop && tracked && !tracked->points_world.empty() &&
      params.max_distance_to_depth_ratio > params.distance_to_depth_ratio) {
    // The parallax a sideways motion of the threshold gives points at the scene depth.
    Eigen::Vector3d closest_centre = camera_centre_world;
    for (const auto& [id, centre] : keyframe_centres) {
      if (id == decision.closest) closest_centre = centre;
    }
    decision.parallax = medianParallax(tracked->points_world, closest_centre, camera_centre_world);
    reach = params.max_distance_to_depth_ratio * scene_depth;
    decision.drop = !(decision.parallax < std::atan(params.distance_to_depth_ratio)) ||
                    decision.distance > reach;
  }
  // Parallax for new points: the camera moved, or the new features' filters measured it (their
  // depths are certain, at a fast pan after a few frames, long before the distance is reached).
  const bool parallax = decision.distance > params.min_distance_fraction * decision.threshold ||
                        (tracked && params.min_certain_candidates > 0 &&
                         tracked->certain_candidates >= params.min_certain_candidates);
  // At an open crossing the near facades leave the view, the median depth of what is left
  // doubles and so does the distance threshold, just when new points are needed most.
  if (!decision.drop && tracked && tracked->at_last_keyframe > 0) {
    decision.view_leaving_map =
        (tracked->now < params.min_tracked_ratio * tracked->at_last_keyframe ||
         tracked->now < params.min_tracked_points) &&
        parallax;
    decision.drop = decision.view_leaving_map;
  }
  // A view that turned away from every nearby keyframe needs new features now, baseline or not:
  // a hand-held pan turns faster than it moves (at 150 deg/s the map's points leave the view
  // within a dozen frames, before their successors' depths are certain), and features are
  // spawned only at keyframes. A camera turning on the spot drops one each time its view leaves
  // the nearby keyframes' (a bounded number per place).
  if (!decision.drop && view && params.max_view_turn_fraction > 0.0) {
    if (view->keyframes.size() != keyframe_centres.size()) {
      throw std::invalid_argument("keyframe rule: one viewing direction per keyframe expected");
    }
    // A nearby keyframe looking elsewhere does not cover this view: when the camera pans, the
    // map points leave the image within a few frames, and new ones are spawned and promoted only
    // at keyframes.
    const double max_turn = params.max_view_turn_fraction * view->field_of_view;
    bool covered = false;
    for (std::size_t k = 0; k < keyframe_centres.size() && !covered; ++k) {
      if ((keyframe_centres[k].second - camera_centre_world).norm() > reach) continue;
      const double cos_turn = std::clamp(view->keyframes[k].dot(view->current), -1.0, 1.0);
      covered = std::acos(cos_turn) <= max_turn;
    }
    decision.view_turned = !covered;
    decision.drop = decision.view_turned;
  }
  return decision;
}

}  // namespace scale_drift_slam::tracking
