#pragma once
// Map versions between the tracking node and a mapping node that may restart. The core tracker
// applies a MapUpdate only when its version is not older than the last one applied; a restarted
// or reset mapping node (a new mapper id) counts from 0 again. The tracking node therefore keeps
// this translation: the first update of a new mapper continues just above the tracker's version,
// later ones keep their distance, updates of retired mappers are dropped, and keyframes report
// the tracker's version in the current mapper's numbering (doc/ros.md). Tracking thread only.

#include <cstdint>
#include <optional>
#include <set>

namespace scale_drift_slam::ros_conversions {

class MapVersionTranslator {
 public:
  /// The version to give the tracker for update `mapper_version` of mapper `mapper_id`, when the
  /// tracker is at `tracker_version`; nothing for an update of a retired mapper or one older than
  /// the current mapper's first. `new_mapper`, when given, says whether a new mapper started.
  std::optional<std::uint64_t> toTracker(std::uint32_t mapper_id, std::uint64_t mapper_version,
                                         std::uint64_t tracker_version, bool* new_mapper = nullptr);
  /// A tracker version in the current mapper's numbering; 0 when none of its updates was applied
  /// yet (or there is no mapper).
  std::uint64_t toMapper(std::uint64_t tracker_version) const;
  /// Forgets every mapper (new tracker session).
  void reset() { *this = MapVersionTranslator(); }

 private:
  bool has_mapper_ = false;
  std::uint32_t mapper_id_ = 0;
  std::uint64_t first_mapper_version_ = 0;   ///< The current mapper's first update...
  std::uint64_t first_tracker_version_ = 0;  ///< ...was given to the tracker as this version.
  std::set<std::uint32_t> retired_;
};

}  // namespace scale_drift_slam::ros_conversions
