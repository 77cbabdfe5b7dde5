#pragma once
// The loop-closure module (doc/algorithm.md, "Loop closure detection"): for every new keyframe,
// place recognition by appearance (PlaceRecognizer) and, for an accepted candidate, metric
// verification (loop_verification.h) giving the 7-DoF loop constraint that the mapper's Sim(3)
// pose graph applies. It also answers relocalisation requests of a lost tracker with the same
// machinery. Runs on the loop-closure thread (offline) or in the loop-closure node.
//
// It keeps its own copy of what it needs of the map (keyframe poses, observations, points),
// built from the keyframe messages and kept current by the mapper's MapUpdates, the place
// recognition database (ORB features per keyframe) and each keyframe's image, JPEG-compressed,
// for the warped patches of verification. Not thread-safe: one owner.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "scale_drift_slam/geometry/camera_model.h"
#include "scale_drift_slam/loop/appearance.h"
#include "scale_drift_slam/loop/loop_constraint.h"
#include "scale_drift_slam/loop/loop_verification.h"
#include "scale_drift_slam/loop/place_recognizer.h"
#include "scale_drift_slam/map/keyframe_message.h"
#include "scale_drift_slam/map/map.h"
#include "scale_drift_slam/map/map_update.h"

namespace scale_drift_slam::loop {

struct LoopCloserParams {
  bool enabled = true;  ///< false: keyframes are only stored (relocalisation still works).
  PlaceRecognitionParams recognition;
  LoopVerificationParams verification;
  /// Keyframes sharing at least this many map points with the query are connected to it already
  /// (the tracker re-found their points): they are not proposed as loops.
  int covisible_min_shared_points = 15;
  int relocalisation_candidates = 5;  ///< Keyframes checked per relocalisation request.
  /// The geometric check of relocalisation candidates: looser than a loop's (a lost camera has
  /// often moved on and overlaps its last keyframes only partly; the metric verification that
  /// follows decides). Defaults: the loop's check with min_inliers 30 and min_coverage 0.3.
  GeometricCheckParams relocalisation_geometry = relaxedGeometry();
  static GeometricCheckParams relaxedGeometry();
  int image_jpeg_quality = 60;  ///< Of the stored keyframe images (progressive JPEG).
  /// Throws std::invalid_argument naming the first bad value.
  void validate() const;
};

/// What became of one keyframe: the place-recognition answer and, when a place was recognised,
/// its verification. `constraint` is set when a loop was verified.
struct LoopDetection {
  map::KeyframeId keyframe_id = 0;
  PlaceQueryResult recognition;
  std::optional<LoopVerification> verification;
  std::optional<LoopConstraint> constraint;
  double recognition_ms = 0.0;   ///< ORB extraction and the query.
  double query_ms = 0.0;         ///< The query alone (its part of recognition_ms).
  double query_cpu_ms = 0.0;     ///< The query's CPU time (unaffected by other processes).
  double verification_ms = 0.0;  ///< 0 when nothing was verified.
  /// One line for logs: the loop found, or why there is none.
  std::string describe() const;
};

class LoopCloser {
 public:
  /// Throws std::invalid_argument on invalid params or a missing camera.
  LoopCloser(std::shared_ptr<const geometry::CameraModel> camera, LoopCloserParams params);

  /// Stores the keyframe (brought into the current world frame if it was made before a loop
  /// correction), searches a loop and verifies it. Keyframes must come in order.
  LoopDetection addKeyframe(map::KeyframeMessage message);
  /// Keeps the map copy current (window BA results and loop corrections).
  void applyMapUpdate(const map::MapUpdate& update);
  /// Localises a frame against the map: place recognition among all keyframes, then verifyPose
  /// against the best places.
  map::RelocalisationAnswer relocalise(const map::RelocalisationRequest& request);

  /// Goes on from a saved state (call on a new LoopCloser only, before any keyframe): the map,
  /// the place-recognition database rebuilt from `places` (with `vocabulary`, or learning one as
  /// the keyframes come when it is null), the keyframes' JPEG images. Throws
  /// std::invalid_argument on a place or image of a keyframe the map does not hold, or an
  /// invalid appearance.
  void restore(map::Map map, std::shared_ptr<const Vocabulary> vocabulary,
               std::vector<SavedPlace> places,
               std::unordered_map<map::KeyframeId, std::vector<std::uint8_t>> jpeg_images);

  const map::Map& map() const { return map_; }
  const PlaceRecognizer& recognizer() const { return recognizer_; }
  /// The stored keyframe images, JPEG-compressed.
  const std::unordered_map<map::KeyframeId, std::vector<std::uint8_t>>& keyframeImages() const {
    return jpeg_images_;
  }
  /// The version of the last MapUpdate applied (0: none).
  std::uint64_t mapVersion() const { return map_version_; }
  std::size_t numKeyframes() const { return map_.numKeyframes(); }
  const LoopCloserParams& params() const { return params_; }

 private:
  /// verification view of a stored keyframe (its image decoded) or of a new one: its own map
  /// points; `with_covisible_points` adds those of its co-visible keyframes that project into
  /// its image (a loop candidate's neighbourhood).
  VerificationView viewOf(map::KeyframeId id, const KeyframeAppearance& features,
                          const cv::Mat& image, bool with_covisible_points = false) const;
  void storeKeyframe(const map::KeyframeMessage& message);
  std::unordered_set<map::KeyframeId> covisibleKeyframes(map::KeyframeId id) const;
  cv::Mat storedImage(map::KeyframeId id) const;

  std::shared_ptr<const geometry::CameraModel> camera_;
  LoopCloserParams params_;
  AppearanceExtractor extractor_;
  PlaceRecognizer recognizer_;
  map::Map map_;
  std::uint64_t map_version_ = 0;  ///< Of the last MapUpdate applied.
  map::CorrectionHistory corrections_;
  std::unordered_map<map::KeyframeId, std::vector<std::uint8_t>> jpeg_images_;
  std::vector<std::uint8_t> jpeg_scratch_;  ///< imencode's buffer, reused for every keyframe.
  int pyramid_levels_ = 2;
};

}  // namespace scale_drift_slam::loop
