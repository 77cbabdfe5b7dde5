#pragma once
// The pose history of every tracked frame, kept in the current world frame. Each frame is
// anchored to its reference keyframe (the newest one when it was tracked) and moves with that
// keyframe's loop correction (MapUpdate::keyframe_corrections, or S_new_old for keyframes the
// correction did not list), so that closing a loop corrects the history instead of leaving a jump
// in it. Used by the offline runner and the tracking node; single-threaded (the tracking thread).

#include <optional>
#include <vector>

#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/map/keyframe_message.h"

namespace scale_drift_slam::map {

class CorrectedTrajectory {
 public:
  struct Frame {
    double timestamp = 0.0;
    geometry::SE3 T_cam_world;
    std::optional<KeyframeId> reference_keyframe;
  };

  void add(double timestamp, const geometry::SE3& T_cam_world,
           std::optional<KeyframeId> reference_keyframe);
  /// Moves the frames by a loop correction (other updates change nothing). Call it when the
  /// tracker applies the same update, so that frames tracked before are exactly those in the old
  /// world frame.
  void apply(const MapUpdate& update);

  /// Forgets all but the newest `count` frames (bounds the memory of a long live run).
  void keepNewest(std::size_t count);

  const std::vector<Frame>& frames() const { return frames_; }
  std::size_t size() const { return frames_.size(); }
  void clear() { frames_.clear(); }

 private:
  std::vector<Frame> frames_;
};

}  // namespace scale_drift_slam::map
