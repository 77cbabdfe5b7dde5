#include "scale_drift_slam/map/corrected_trajectory.h"

#include <unordered_map>

#include "scale_drift_slam/map/map_update.h"

namespace scale_drift_slam::map {

void CorrectedTrajectory::add(double timestamp, const geometry::SE3& T_cam_world,
                              std::optional<KeyframeId> reference_keyframe) {
  frames_.push_back({timestamp, T_cam_world, reference_keyframe});
}

void CorrectedTrajectory::keepNewest(std::size_t count) {
  if (frames_.size() > count) {
    frames_.erase(frames_.begin(), frames_.end() - static_cast<std::ptrdiff_t>(count));
  }
}

void CorrectedTrajectory::apply(const MapUpdate& update) {
  if (!update.S_new_old) return;
  std::unordered_map<KeyframeId, const geometry::Sim3*> corrections;
  for (const auto& [id, C] : update.keyframe_corrections)
    corrections[id] = &C;
  for (Frame& frame : frames_) {
    const geometry::Sim3* C = &*update.S_new_old;
    if (frame.reference_keyframe) {
      const auto it = corrections.find(*frame.reference_keyframe);
      if (it != corrections.end()) C = it->second;
    }
    frame.T_cam_world = correctPose(frame.T_cam_world, *C);
  }
}

}  // namespace scale_drift_slam::map
