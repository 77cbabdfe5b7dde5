#include "scale_drift_slam/system/map_versions.h"

#include <algorithm>

namespace scale_drift_slam::system {

std::uint64_t MapVersionTranslator::translate(const Epoch& epoch, std::uint64_t mapper_version) {
  if (mapper_version >= epoch.first_mapper_version) {
    return epoch.first_tracker_version + (mapper_version - epoch.first_mapper_version);
  }
  const std::uint64_t below = epoch.first_mapper_version - mapper_version;
  return epoch.first_tracker_version > below ? epoch.first_tracker_version - below : 0;
}

std::optional<std::uint64_t> MapVersionTranslator::toTracker(std::uint32_t mapper_id,
                                                             std::uint64_t mapper_version,
                                                             std::uint64_t tracker_version,
                                                             bool* new_mapper) {
  if (new_mapper) *new_mapper = false;
  if (retired_.count(mapper_id)) return std::nullopt;
  if (!has_mapper_ || mapper_id != mapper_id_) {
    if (has_mapper_) retired_[mapper_id_] = current_;
    has_mapper_ = true;
    mapper_id_ = mapper_id;
    current_.first_mapper_version = mapper_version;
    // Identity when possible (a first mapper); otherwise just above the consumer's version.
    current_.first_tracker_version = std::max(tracker_version + 1, mapper_version);
    if (new_mapper) *new_mapper = true;
    return current_.first_tracker_version;
  }
  if (mapper_version < current_.first_mapper_version) return std::nullopt;
  return translate(current_, mapper_version);
}

std::uint64_t MapVersionTranslator::toMapper(std::uint64_t tracker_version) const {
  if (!has_mapper_ || tracker_version < current_.first_tracker_version) return 0;
  return current_.first_mapper_version + (tracker_version - current_.first_tracker_version);
}

std::optional<std::uint64_t> MapVersionTranslator::toConsumer(std::uint32_t mapper_id,
                                                              std::uint64_t mapper_version) const {
  if (mapper_id == 0) return 0;
  if (has_mapper_ && mapper_id == mapper_id_) return translate(current_, mapper_version);
  const auto retired = retired_.find(mapper_id);
  if (retired != retired_.end()) return translate(retired->second, mapper_version);
  return std::nullopt;
}

}  // namespace scale_drift_slam::system
