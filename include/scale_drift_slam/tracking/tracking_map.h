#pragma once
// The tracker's own copy of the map: the keyframe poses and the points it searches for, each
// point with its appearance (patches from its reference keyframe). The mapper owns the global map
// and corrects this copy through map::MapUpdate messages, applied by the tracking thread between
// frames, so tracking never waits for a lock. Owned by the Tracker; single-threaded.

#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include <Eigen/Core>

#include "scale_drift_slam/features/active_search.h"
#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/map/keyframe_message.h"
#include "scale_drift_slam/map/map.h"

namespace scale_drift_slam::tracking {

struct TrackedPoint {
  map::PointId id = 0;
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
  map::KeyframeId reference_keyframe = 0;
  features::PointAppearance appearance;
  int times_searched = 0;                 ///< Frames in which active search tried to match it.
  int times_found = 0;                    ///< ...and matched it.
  std::uint64_t last_selected_frame = 0;  ///< Bookkeeping of localPoints() (or its creation).
};

struct TrackedKeyframe {
  map::KeyframeId id = 0;
  double timestamp = 0.0;
  geometry::SE3 T_kf_world;
  std::vector<map::PointId> points;  ///< Points it observes (or is the reference of).
  /// The points made at this keyframe or later have ids from this one on (ids only grow).
  map::PointId first_new_point = 0;
};

class TrackingMap {
 public:
  void addKeyframe(TrackedKeyframe keyframe);
  void addPoint(TrackedPoint point);
  /// Records that a keyframe sees a point (for the selection of local points).
  void linkPoint(map::KeyframeId keyframe, map::PointId point);
  /// Joins two keyframes that a loop closure found to show the same place: each becomes a
  /// neighbour of the other in the local map's graph.
  void linkKeyframes(map::KeyframeId a, map::KeyframeId b);

  /// Applies a mapper correction: the optional similarity first, then poses and positions of
  /// known ids, then removals (points; the observations of culled keyframes, whose poses stay
  /// for the keyframe rule and the points' patches). Updates older than the last applied
  /// version are ignored. Returns false when ignored.
  bool apply(const map::MapUpdate& update);

  /// The keyframes the tracker made after the newest one a bundle-adjustment update moves (the
  /// update's anchor) ride with it: the world correction C (p -> C p) that takes the anchor from
  /// its pose here to its pose in `update`, for apply() to be followed by moveTail(). None when
  /// the update corrects a loop (S_new_old moves everything), moves no keyframe held here, or no
  /// keyframe here is newer than its anchor.
  struct TailCorrection {
    map::KeyframeId anchor = 0;
    geometry::SE3 C_new_old;
  };
  std::optional<TailCorrection> tailCorrection(const map::MapUpdate& update) const;
  /// Moves the keyframes newer than `tail.anchor` and the points made at them (which no update
  /// can place yet: the mapper has not seen them) by `tail.C_new_old`.
  void moveTail(const TailCorrection& tail);

  /// The local map (ids, each once): the points of the `num_recent` newest keyframes and of the
  /// `num_nearest` keyframes closest to `camera_centre` among the neighbourhood of the tracked
  /// region (the newest ones may be among them; then fewer keyframes are searched: keeping the
  /// two sets apart searched more but lost 5 of the 6 loops on sphere_flyover). The region is the
  /// newest keyframes and those observing `tracked` (the points found in the previous frame); its
  /// neighbourhood is what the graph of co-visibility (keyframes sharing at least `min_shared`
  /// points) and loop links reaches from it in two steps. So points of a distant part of the map
  /// are not searched just because the drifted pose estimate comes near it: a large loop is closed
  /// by loop closure (Sim(3), scale included), not by silently re-finding old points in a drifted
  /// frame. `frame` stamps the selection; the selected points' patches are expanded.
  std::vector<map::PointId> localPoints(const Eigen::Vector3d& camera_centre, int num_recent,
                                        int num_nearest, const std::vector<map::PointId>& tracked,
                                        int min_shared, std::uint64_t frame);
  /// Compresses the patches of the points not selected by localPoints() (nor created) in the
  /// last `idle_frames` frames before `frame` (PointAppearance::compress); localPoints() expands
  /// them again when it selects them. Visits only the points queued `idle_frames` ago or
  /// earlier. Returns how many it compressed.
  std::size_t compressIdlePatches(std::uint64_t frame, std::uint64_t idle_frames);
  /// The keyframes within `steps` of `start` in that graph (start included).
  std::unordered_set<map::KeyframeId> neighbourhood(const std::vector<map::KeyframeId>& start,
                                                    int steps, int min_shared) const;
  /// Keyframe centres (id, centre in the world) for the keyframe rule.
  std::vector<std::pair<map::KeyframeId, Eigen::Vector3d>> keyframeCentres() const;
  /// Keyframe viewing directions (unit optical axes in the world), in the order of the centres.
  std::vector<Eigen::Vector3d> keyframeViewAxes() const;

  bool hasPoint(map::PointId id) const { return points_.count(id) != 0; }
  bool hasKeyframe(map::KeyframeId id) const { return keyframes_.count(id) != 0; }
  TrackedPoint& point(map::PointId id) { return points_.at(id); }
  const TrackedPoint& point(map::PointId id) const { return points_.at(id); }
  const TrackedKeyframe& keyframe(map::KeyframeId id) const { return keyframes_.at(id); }
  const std::map<map::KeyframeId, TrackedKeyframe>& keyframes() const { return keyframes_; }
  std::size_t numPoints() const { return points_.size(); }
  std::size_t numKeyframes() const { return keyframes_.size(); }
  std::uint64_t version() const { return version_; }

 private:
  std::map<map::KeyframeId, TrackedKeyframe> keyframes_;
  std::unordered_map<map::PointId, TrackedPoint> points_;
  std::uint64_t version_ = 0;
  /// Points whose patches are expanded, each with the frame it was queued at (added, expanded,
  /// or found still in use by compressIdlePatches): the sweep visits only the points due, not the
  /// whole map (a pass over 50 000 points cost the keyframe frame it ran on milliseconds).
  std::deque<std::pair<map::PointId, std::uint64_t>> expanded_queue_;
  /// The graph of the local map: keyframes observing each point, shared points per keyframe
  /// pair, loop links.
  void addObservation(map::KeyframeId keyframe, map::PointId point);
  void removePoint(map::PointId id);
  void cullKeyframe(map::KeyframeId id);
  /// Takes the shared points of every pair of `observers` down by one.
  void forgetObservers(const std::vector<map::KeyframeId>& observers);
  void unshare(map::KeyframeId a, map::KeyframeId b);  ///< One point fewer shared (a -> b).
  std::unordered_map<map::PointId, std::vector<map::KeyframeId>> observers_;
  std::unordered_map<map::KeyframeId, std::unordered_map<map::KeyframeId, int>> shared_;
  std::unordered_map<map::KeyframeId, std::vector<map::KeyframeId>> links_;
};

}  // namespace scale_drift_slam::tracking
