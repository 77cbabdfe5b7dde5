#pragma once
// The keyframe rule (doc/algorithm.md, "Front-end: keyframe dropping"): drop a new keyframe as
// soon as the distance from the current camera to the closest keyframe exceeds a threshold. The
// map's scale drifts, so the threshold is a fraction of the scene depth (the median depth of the
// points the camera tracks), not a fixed distance. Our addition for weakly textured scenes and
// narrow lenses: also drop one when most of the map points tracked at the last keyframe have left
// the view, so that new points enter the map before the old ones are all gone, and when the view
// has turned away from every nearby keyframe (a fast pan: the candidates of new points are spawned
// and promoted only at keyframes, and must be before the map has left the view). Pure functions;
// any thread.

#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/map/map.h"

namespace scale_drift_slam::tracking {

struct KeyframeRuleParams {
  /// Drop when the distance to the closest keyframe exceeds this fraction of the scene depth.
  double distance_to_depth_ratio = 0.1;
  /// Forward motion: past that distance the keyframe waits until the tracked points' median
  /// parallax between the closest keyframe and the camera reaches atan(distance_to_depth_ratio)
  /// (what the distance gives a sideways motion), but never beyond this fraction of the scene
  /// depth. Driving forward, points near the direction of travel gain little parallax, and the
  /// distance alone makes a keyframe every other frame (0: the distance alone).
  double max_distance_to_depth_ratio = 0.25;
  /// Also drop when the map points tracked fall below this fraction of those tracked at the last
  /// keyframe (0: never)...
  double min_tracked_ratio = 0.5;
  /// ...or below this many, whatever the last keyframe had (weak tracking: the map is starving,
  /// and new points are promoted only at keyframes; a last keyframe that was already starved
  /// makes the ratio useless; 0: never)...
  int min_tracked_points = 50;
  /// ...once the camera has moved this fraction of the distance threshold (parallax for the new
  /// points).
  double min_distance_fraction = 0.25;
  /// ...or once this many new features have a certain depth (they are promoted at the keyframe;
  /// 0: the distance alone).
  int min_certain_candidates = 40;
  /// Also drop when the viewing direction is more than this fraction of the camera's (narrowest)
  /// field of view away from that of every keyframe within the distance threshold, parallax or
  /// not (0: never).
  double max_view_turn_fraction = 0.25;
  /// Throws std::invalid_argument naming the bad value.
  void validate() const;
};

/// Map points tracked in the current frame and in the frame of the last keyframe.
struct TrackedPoints {
  int now = 0;
  int at_last_keyframe = 0;
  /// New features whose depth is certain (they are promoted at the next keyframe).
  int certain_candidates = 0;
  /// World positions of the map points tracked now (the parallax of forward motion).
  std::vector<Eigen::Vector3d> points_world = {};
};

/// Viewing directions (unit optical axes in the world) for the view-turn rule.
struct ViewDirections {
  Eigen::Vector3d current = Eigen::Vector3d::UnitZ();
  std::vector<Eigen::Vector3d> keyframes;  ///< In the order of the keyframe centres.
  double field_of_view = 0.0;              ///< The narrowest angular extent of the image (rad).
};

struct KeyframeDecision {
  bool drop = false;
  bool view_leaving_map = false;  ///< Dropped for the tracked points, not the distance.
  bool view_turned = false;       ///< Dropped for the viewing direction, not the distance.
  double distance = 0.0;   ///< To the closest keyframe (map units); infinity when there is none.
  double threshold = 0.0;  ///< distance_to_depth_ratio * scene depth.
  /// Median parallax (rad) of the tracked points between the closest keyframe and the camera;
  /// NaN when not measured (the distance alone decided).
  double parallax = std::numeric_limits<double>::quiet_NaN();
  map::KeyframeId closest = 0;
};

/// Why a keyframe was dropped, for the frame's message ("keyframe: moved 1.6 of 1.5", "keyframe:
/// view leaving the map", "keyframe: view turned").
std::string keyframeReason(const KeyframeDecision& decision);

/// The median over `points_world` of the angle between the rays from `from` and from `to` to
/// the point (rad); NaN when there is no point.
double medianParallax(const std::vector<Eigen::Vector3d>& points_world, const Eigen::Vector3d& from,
                      const Eigen::Vector3d& to);

/// The median depth (z in the camera) of the given world points that lie in front of the camera.
/// Throws std::invalid_argument when none does.
double medianSceneDepth(const geometry::SE3& T_cam_world,
                        const std::vector<Eigen::Vector3d>& points_world);

/// Applies the rule. `keyframe_centres` are (id, camera centre in the world); with none, the
/// decision is to drop. Without `tracked` and `view`, the distance rule alone (the paper's).
/// Throws std::invalid_argument for a non-positive or non-finite depth, or `view` with a number of
/// keyframe directions other than that of the centres.
KeyframeDecision decideKeyframe(
    const Eigen::Vector3d& camera_centre_world,
    const std::vector<std::pair<map::KeyframeId, Eigen::Vector3d>>& keyframe_centres,
    double scene_depth, const KeyframeRuleParams& params,
    const std::optional<TrackedPoints>& tracked = std::nullopt,
    const std::optional<ViewDirections>& view = std::nullopt);

}  // namespace scale_drift_slam::tracking
