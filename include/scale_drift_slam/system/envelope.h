#pragma once
// The address every message between the tracker, the mapper and the loop closer carries, offline
// (system::SlamSystem's queues) and between the ROS nodes (the `session`, `mapper_id` and
// `map_version` fields of the messages) alike:
// - `session`: the tracker session the message belongs to. The tracker starts a new one whenever
//   it starts a new map (start, reset, a young lost map discarded); a keyframe of a new session
//   starts a new map at the mapper and the loop closer, anything else of another session is
//   dropped.
// - `mapper_id` and `map_version`: the map version the message was made at, in the numbering of
//   the mapper that made it (0, 0: before any map update). A mapper that restarts counts from 0
//   again under a new id; receivers translate (map_versions.h).

#include <cstdint>

namespace scale_drift_slam::system {

struct Envelope {
  std::uint32_t session = 0;
  std::uint32_t mapper_id = 0;
  std::uint64_t map_version = 0;
};

/// A message with its address.
template <typename Message>
struct Addressed {
  Envelope from;
  Message message;
};

}  // namespace scale_drift_slam::system
