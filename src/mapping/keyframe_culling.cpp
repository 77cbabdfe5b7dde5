#include "scale_drift_slam/mapping/keyframe_culling.h"

#include <cmath>
#include <iterator>
#include <stdexcept>

namespace scale_drift_slam::mapping {

void KeyframeCullingParams::validate() const {
  if (!(redundant_ratio >= 0.0 && redundant_ratio <= 1.0)) {
    throw std::invalid_argument("keyframe culling: redundant_ratio must be in [0, 1]");
  }
  if (min_other_observers < 1) {
    throw std::invalid_argument("keyframe culling: min_other_observers must be >= 1");
  }
}

std::optional<map::KeyframeId> redundantKeyframe(const map::Map& map, int window_size,
                                                 const KeyframeCullingParams& params,
                                                 const std::unordered_set<map::KeyframeId>& keep) {
  params.validate();
  if (params.redundant_ratio <= 0.0 || window_size < 0) return std::nullopt;
  // The examined keyframe and the oldest must differ: more than window_size + 1 keyframes.
  if (map.numKeyframes() < static_cast<std::size_t>(window_size) + 2) return std::nullopt;
  const map::Keyframe& candidate = std::prev(map.keyframes().end(), window_size + 1)->second;
  if (candidate.id == map.keyframes().begin()->first || keep.count(candidate.id) != 0 ||
      candidate.observations.empty()) {
    return std::nullopt;
  }
  std::size_t covered = 0;
  for (const map::Observation& observation : candidate.observations) {
    const std::size_t others = map.point(observation.point_id).observed_by.size() - 1;
    if (others >= static_cast<std::size_t>(params.min_other_observers)) ++covered;
  }
  const double needed = params.redundant_ratio * static_cast<double>(candidate.observations.size());
  if (static_cast<double>(covered) < needed) return std::nullopt;
  return candidate.id;
}

}  // namespace scale_drift_slam::mapping
