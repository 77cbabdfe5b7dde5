#pragma once
// The checks every message between the tracker, the mapper and the loop closer passes before it
// can change any state, offline (system::SlamSystem's queues) and between the ROS nodes alike (the
// nodes convert, then call the same endpoints, which call these). Each returns why the message is
// refused, or an empty string when it may go on; a refused message changes nothing.
// - Content (context-free): finite numbers (poses, points, normalised coordinates, Sim(3)
//   scales, stamps), translations and points within `max_coordinate` of the origin, Sim(3) scales
//   within a factor `max_scale_ratio` of 1, bounded sizes (observations, new points, update
//   entries, found points, image sides), ids not ahead of the message's own keyframe.
// - Ids against what the sender can have: a keyframe id far ahead of the newest one the receiver
//   holds of that session (keyframeIdProblem); a map update or a relocalisation answer naming a
//   keyframe the tracker never made (trackerIdsProblem): the tracker makes every keyframe, so
//   nobody can know of a later one.

#include <optional>
#include <string>

#include "scale_drift_slam/geometry/camera_calibration.h"
#include "scale_drift_slam/loop/loop_constraint.h"
#include "scale_drift_slam/map/keyframe_message.h"

namespace scale_drift_slam::system {

struct MessageLimits {
  int max_observations = 10000;  ///< Per keyframe, its own and the earlier ones each.
  int max_new_points = 10000;    ///< Points promoted at one keyframe.
  /// A keyframe id more than this above the newest one held of its session is refused (keyframes
  /// lost on the way leave gaps; a forged id far ahead would block the real keyframe later).
  int max_keyframe_id_gap = 1000;
  int max_update_entries = 2000000;  ///< Poses, points, corrections of one map update, each.
  int max_found_points = 20000;      ///< Points of one relocalisation answer.
  int max_image_side = 16384;        ///< Pixels, of the images keyframes and requests carry.
  double max_coordinate = 1e6;       ///< |translation| and |point| in map units.
  double max_normalised = 1e3;       ///< |xy| of an observation (normalised image coordinates).
  double max_scale_ratio = 1e4;      ///< Sim(3) scales within [1/r, r].
  /// Throws std::invalid_argument naming the first bad value.
  void validate() const;
};

/// A keyframe's content: stamp, pose, observations, new points, image size.
std::string keyframeProblem(const map::KeyframeMessage& keyframe, const MessageLimits& limits);
/// The camera a keyframe comes with (zero, non-finite or absurd intrinsics).
std::string cameraProblem(const geometry::CameraCalibration& camera);
/// `id` against the newest keyframe id the receiver holds of the keyframe's session (none: any id
/// may begin or join the session).
std::string keyframeIdProblem(map::KeyframeId id, std::optional<map::KeyframeId> newest_held,
                              const MessageLimits& limits);
std::string mapUpdateProblem(const map::MapUpdate& update, const MessageLimits& limits);
std::string loopConstraintProblem(const loop::LoopConstraint& constraint,
                                  const MessageLimits& limits);
std::string relocalisationRequestProblem(const map::RelocalisationRequest& request,
                                         const MessageLimits& limits);
std::string relocalisationAnswerProblem(const map::RelocalisationAnswer& answer,
                                        const MessageLimits& limits);
/// For the tracker's inbox: keyframe ids of an update or an answer above `newest_made` (the
/// tracker's newest keyframe; none yet: every id is ahead).
std::string trackerIdsProblem(const map::MapUpdate& update,
                              std::optional<map::KeyframeId> newest_made);
std::string trackerIdsProblem(const map::RelocalisationAnswer& answer,
                              std::optional<map::KeyframeId> newest_made);

}  // namespace scale_drift_slam::system
