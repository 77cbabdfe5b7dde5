#pragma once
// The loop closer as the tracker and the mapper reach it: addressed keyframes, map updates and
// relocalisation requests in (envelope.h); addressed loop constraints and relocalisation answers
// out. It owns the session rule of the loop closer's side: a new tracker session's first keyframe
// (id 0) starts a new LoopCloser (with the camera the keyframe comes with), checked before the old
// one is thrown away, and no other keyframe of another session replaces it; updates of another
// session are dropped; every message is validated first (message_validation.h) and a refused one
// changes nothing; a restarted mapper is followed through map-version epochs (map_versions.h)
// and the loop closer's copy of the map is kept. Driven by system::SlamSystem's loop thread offline
// and by the ROS loop-closure node's worker thread.

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "scale_drift_slam/geometry/camera_model.h"
#include "scale_drift_slam/loop/loop_closer.h"
#include "scale_drift_slam/system/envelope.h"
#include "scale_drift_slam/system/map_versions.h"
#include "scale_drift_slam/system/message_validation.h"

namespace scale_drift_slam::system {

class LoopCloserEndpoint {
 public:
  using CameraSource = std::function<std::shared_ptr<const geometry::CameraModel>()>;

  /// `limits`: what a message must pass to be taken (message_validation.h).
  explicit LoopCloserEndpoint(loop::LoopCloserParams params, MessageLimits limits = {});

  struct KeyframeOutcome {
    bool added = false;
    bool new_session = false;  ///< It started a new LoopCloser (first, or a new tracker session).
    std::string refusal;       ///< Why it was not added.
    std::optional<loop::LoopDetection> detection;
    std::optional<Addressed<loop::LoopConstraint>> constraint;  ///< A verified loop.
  };
  /// `camera` is asked only when the keyframe starts a new session; when it throws, nothing
  /// changes.
  KeyframeOutcome addKeyframe(const Envelope& from, map::KeyframeMessage keyframe,
                              const CameraSource& camera);

  struct UpdateOutcome {
    bool applied = false;
    bool new_mapper = false;  ///< The first update of a mapper after another one's.
    std::string refusal;      ///< Why an invalid update was refused (message_validation.h).
  };
  UpdateOutcome applyMapUpdate(const Envelope& from, map::MapUpdate update);

  /// Answers a request; one of another session, or an invalid one, fails with the reason.
  Addressed<map::RelocalisationAnswer> relocalise(const Envelope& from,
                                                  const map::RelocalisationRequest& request);

  /// Takes a saved map as the loop closer of tracker session `session` (loop::LoopCloser::
  /// restore). Throws what the LoopCloser throws; nothing changes then.
  void restore(std::uint32_t session, std::shared_ptr<const geometry::CameraModel> camera,
               map::Map map, std::shared_ptr<const loop::Vocabulary> vocabulary,
               std::vector<loop::SavedPlace> places,
               std::unordered_map<map::KeyframeId, std::vector<std::uint8_t>> jpeg_images);

  /// The loop closer of the current session; nullptr before the first keyframe.
  const loop::LoopCloser* closer() const { return closer_ ? &*closer_ : nullptr; }
  std::uint32_t session() const { return session_; }

 private:
  bool isCurrent(std::uint32_t session) const { return closer_ && session == session_; }
  Envelope address(std::uint64_t loop_closer_version) const {
    return {session_, versions_.mapperId(), versions_.toMapper(loop_closer_version)};
  }

  std::string admissionProblem(const Envelope& from, const map::KeyframeMessage& keyframe) const;

  loop::LoopCloserParams params_;
  MessageLimits limits_;
  std::uint32_t session_ = 0;
  std::optional<loop::LoopCloser> closer_;
  MapVersionTranslator versions_;
};

}  // namespace scale_drift_slam::system
