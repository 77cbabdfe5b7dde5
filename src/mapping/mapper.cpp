#include "scale_drift_slam/mapping/mapper.h"

#include <stdexcept>

namespace scale_drift_slam::mapping {

void MapperParams::validate() const {
  window.validate();
}

Mapper::Mapper(const MapperParams& params, double focal_length_px)
    : params_(params), focal_length_px_(focal_length_px) {
  params_.validate();
  if (!(focal_length_px_ > 0.0))
    throw std::invalid_argument("mapper needs a positive focal length");
}

map::MapUpdate Mapper::addKeyframe(const map::KeyframeMessage& message,
                                   BundleStatistics* statistics) {
  for (const map::NewMapPoint& point : message.new_points) {
    if (map_.hasPoint(point.id)) continue;
    map_.addPoint({point.id, point.p_world, point.reference_keyframe, {}});
  }
  map::Keyframe keyframe = message.keyframe;
  keyframe.observations.clear();
  for (const map::Observation& observation : message.keyframe.observations) {
    if (map_.hasPoint(observation.point_id)) keyframe.observations.push_back(observation);
  }
  map_.addKeyframe(std::move(keyframe));
  for (const map::KeyframeObservation& o : message.earlier_observations) {
    if (map_.hasKeyframe(o.keyframe_id) && map_.hasPoint(o.point_id)) {
      map_.addObservation(o.keyframe_id, o.point_id, o.xy);
    }
  }

  map::MapUpdate update;
  if (statistics) *statistics = BundleStatistics{};
  const bool enough = static_cast<int>(map_.numKeyframes()) > params_.window.num_fixed_keyframes;
  if (params_.run_window_ba && enough) {
    const WindowBundleInput input = makeWindowInput(map_, params_.window, focal_length_px_);
    const WindowBundleResult result = solveWindowBundleAdjustment(input, params_.window);
    applyWindowResult(result, map_);
    if (statistics) *statistics = result.statistics;
    for (const BundleKeyframe& kf : result.keyframes) {
      if (!kf.fixed) update.keyframe_poses.emplace_back(kf.id, kf.T_kf_world);
    }
    for (const BundlePoint& p : result.points) {
      if (!p.fixed) update.point_positions.emplace_back(p.id, p.p_world);
    }
  }
  update.map_version = map_.version();
  return update;
}

}  // namespace scale_drift_slam::mapping
