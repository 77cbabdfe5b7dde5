#include "scale_drift_slam/ros/map_versions.h"

#include <algorithm>

namespace scale_drift_slam::ros_conversions {

std::optional<std::uint64_t> MapVersionTranslator::toTracker(std::uint32_t mapper_id,
                                                             std::uint64_t mapper_version,
                                                             std::uint64_t tracker_version,
                                                             bool* new_mapper) {
  if (new_mapper) *new_mapper = false;
  if (retired_.count(mapper_id)) return std::nullopt;
  if (!has_mapper_ || mapper_id != mapper_id_) {
    if (has_mapper_) retired_.insert(mapper_id_);
    has_mapper_ = true;
    mapper_id_ = mapper_id;
    first_mapper_version_ = mapper_version;
    // Identity when possible (a first mapper); otherwise just above the tracker's version.
    first_tracker_version_ = std::max(tracker_version + 1, mapper_version);
    if (new_mapper) *new_mapper = true;
    return first_tracker_version_;
  }
  if (mapper_version < first_mapper_version_) return std::nullopt;
  return first_tracker_version_ + (mapper_version - first_mapper_version_);
}

std::uint64_t MapVersionTranslator::toMapper(std::uint64_t tracker_version) const {
  if (!has_mapper_ || tracker_version < first_tracker_version_) return 0;
  return first_mapper_version_ + (tracker_version - first_tracker_version_);
}

}  // namespace scale_drift_slam::ros_conversions
