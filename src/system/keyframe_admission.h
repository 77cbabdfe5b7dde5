#pragma once
// Private to src/system: the session rule for an addressed keyframe, shared by the mapper's and
// the loop closer's endpoints.

#include <cstdint>
#include <string>

#include "scale_drift_slam/map/map.h"
#include "scale_drift_slam/system/envelope.h"

namespace scale_drift_slam::system::internal {

/// Why `keyframe`, addressed `from`, may not enter a part that holds `what` of tracker session
/// `session` (`holds_map` false: nothing yet); empty when it may. Never with a non-finite pose.
/// Of another session only when it begins a map (id 0: a new tracker session begins with
/// keyframe 0) or when the part holds nothing (it joins a running session): anything else would
/// throw the map away for a message that cannot be the start of one (stray or forged).
inline std::string keyframeRefusal(const Envelope& from, const map::Keyframe& keyframe,
                                   bool holds_map, std::uint32_t session, const std::string& what) {
  const std::string name = "keyframe " + std::to_string(keyframe.id);
  if (!keyframe.T_kf_world.matrix().allFinite()) return name + " has a non-finite pose";
  if (holds_map && from.session != session && keyframe.id != 0) {
    return name + " of tracker session " + std::to_string(from.session) +
           " does not begin a map: the " + what + " of session " + std::to_string(session) +
           " is kept";
  }
  return "";
}

}  // namespace scale_drift_slam::system::internal
