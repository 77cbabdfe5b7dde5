#pragma once
// Map versions between a consumer of map updates (the tracking node's tracker, the loop-closure
// node's loop closer) and a mapping node that may restart. The core applies a MapUpdate only when
// its version is not older than the last one applied, and a keyframe or relocalisation answer
// made before a loop correction is recognised by its version; a restarted or reset mapping node
// (a new mapper id) counts from 0 again. Each consumer therefore keeps this translation: the
// first update of a new mapper continues just above the consumer's version, later ones keep their
// distance, updates of retired mappers are dropped, and versions are reported to other nodes in
// the numbering of a named mapper (doc/ros.md). One thread only (the consumer's).

#include <cstdint>
#include <map>
#include <optional>

namespace scale_drift_slam::system {

class MapVersionTranslator {
 public:
  /// The version to give the consumer for update `mapper_version` of mapper `mapper_id`, when the
  /// consumer is at `tracker_version`; nothing for an update of a retired mapper or one older than
  /// the current mapper's first. `new_mapper`, when given, says whether a new mapper started.
  std::optional<std::uint64_t> toTracker(std::uint32_t mapper_id, std::uint64_t mapper_version,
                                         std::uint64_t tracker_version, bool* new_mapper = nullptr);
  /// A consumer version in the current mapper's numbering; 0 when none of its updates was applied
  /// yet (or there is no mapper).
  std::uint64_t toMapper(std::uint64_t tracker_version) const;
  /// A version another node reports in the numbering of mapper `mapper_id` (a keyframe's, a
  /// relocalisation answer's) in the consumer's numbering: 0 for mapper id 0 (no update applied),
  /// the same translation as toTracker for the current and retired mappers (clamped at 0 below a
  /// mapper's first update), nothing for a mapper this consumer has not met yet.
  std::optional<std::uint64_t> toConsumer(std::uint32_t mapper_id,
                                          std::uint64_t mapper_version) const;
  /// The current mapper (0: none yet).
  std::uint32_t mapperId() const { return has_mapper_ ? mapper_id_ : 0; }
  /// Forgets every mapper (new tracker session).
  void reset() { *this = MapVersionTranslator(); }

 private:
  struct Epoch {
    std::uint64_t first_mapper_version = 0;   ///< The mapper's first update...
    std::uint64_t first_tracker_version = 0;  ///< ...was given to the consumer as this version.
  };
  static std::uint64_t translate(const Epoch& epoch, std::uint64_t mapper_version);

  bool has_mapper_ = false;
  std::uint32_t mapper_id_ = 0;
  Epoch current_;
  std::map<std::uint32_t, Epoch> retired_;
};

}  // namespace scale_drift_slam::system
