#include "scale_drift_slam/mapping/point_culling.h"

#include <algorithm>
#include <iterator>
#include <stdexcept>

namespace scale_drift_slam::mapping {

void PointCullingParams::validate() const {
  if (min_keyframes < 0) throw std::invalid_argument("point culling: min_keyframes must be >= 0");
  if (after_keyframes < 1) {
    throw std::invalid_argument("point culling: after_keyframes must be >= 1");
  }
}

std::vector<map::PointId> weakPoints(const map::Map& map, const PointCullingParams& params) {
  params.validate();
  std::vector<map::PointId> weak;
  if (params.min_keyframes == 0 ||
      map.numKeyframes() <= static_cast<std::size_t>(params.after_keyframes)) {
    return weak;
  }
  const auto& keyframes = map.keyframes();
  const map::Keyframe& aged = std::prev(keyframes.end(), params.after_keyframes + 1)->second;
  const geometry::SE3& T_newest_world = keyframes.rbegin()->second.T_kf_world;
  for (const map::Observation& observation : aged.observations) {
    const map::MapPoint& point = map.point(observation.point_id);
    if (static_cast<int>(point.observed_by.size()) >= params.min_keyframes) continue;
    if ((T_newest_world * point.p_world).z() > 0.0) continue;  // still ahead: may be found again
    const map::KeyframeId newest =
        *std::max_element(point.observed_by.begin(), point.observed_by.end());
    if (newest == aged.id) weak.push_back(point.id);
  }
  std::sort(weak.begin(), weak.end());
  weak.erase(std::unique(weak.begin(), weak.end()), weak.end());
  return weak;
}

}  // namespace scale_drift_slam::mapping
