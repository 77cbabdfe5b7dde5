#include "scale_drift_slam/loop/loop_closer.h"

#include <cstdio>
#include <optional>
#include <stdexcept>
#include <unordered_set>

#include <opencv2/imgcodecs.hpp>

#include "scale_drift_slam/common/stopwatch.h"

namespace scale_drift_slam::loop {
namespace {

std::string format(const char* pattern, double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), pattern, value);
  return buffer;
}

}  // namespace

GeometricCheckParams LoopCloserParams::relaxedGeometry() {
  GeometricCheckParams geometry;
  geometry.min_inliers = 30;
  geometry.min_coverage = 0.3;
  return geometry;
}

void LoopCloserParams::validate() const {
  recognition.validate();
  relocalisation_geometry.validate();
  verification.validate();
  if (covisible_min_shared_points < 1) {
    throw std::invalid_argument("loop closer: covisible_min_shared_points must be >= 1");
  }
  if (relocalisation_candidates < 1) {
    throw std::invalid_argument("loop closer: relocalisation_candidates must be >= 1");
  }
  if (image_jpeg_quality < 1 || image_jpeg_quality > 100) {
    throw std::invalid_argument("loop closer: image_jpeg_quality must be in [1, 100]");
  }
}

std::string LoopDetection::describe() const {
  std::string text = recognition.describe();
  if (!verification) return text;
  const LoopVerification& v = *verification;
  text += constraint ? "; verified: " : "; rejected by verification: " + v.reason + " (";
  text += std::to_string(v.descriptor_matches) + " descriptor matches, " +
          std::to_string(v.matches_with_depth) + " with depth, " +
          std::to_string(v.ransac_inliers) + " RANSAC inliers, " + std::to_string(v.found_points) +
          " of " + std::to_string(v.searched_points) + " map points found, " +
          std::to_string(v.constraint.num_inliers) + " final inliers";
  if (constraint) {
    text += ", scale " + format("%.4f", constraint->scale) + " from " +
            std::to_string(constraint->num_scale_pairs) + " pairs, " +
            format("%.2f", constraint->rmse_px) + " px RMSE";
  } else {
    text += ")";
  }
  return text;
}

LoopCloser::LoopCloser(std::shared_ptr<const geometry::CameraModel> camera, LoopCloserParams params)
    : camera_(std::move(camera)),
      params_(std::move(params)),
      extractor_(params_.recognition.appearance),
      recognizer_(params_.recognition) {
  params_.validate();
  if (!camera_) throw std::invalid_argument("loop closer: a camera model is needed");
}

void LoopCloser::restore(
    map::Map map, std::shared_ptr<const Vocabulary> vocabulary, std::vector<SavedPlace> places,
    std::unordered_map<map::KeyframeId, std::vector<std::uint8_t>> jpeg_images) {
  if (map_.numKeyframes() != 0 || recognizer_.size() != 0) {
    throw std::logic_error("loop closer: a map can only be restored into a new loop closer");
  }
  PlaceRecognizer recognizer(params_.recognition, std::move(vocabulary));
  for (SavedPlace& place : places) {
    if (!map.hasKeyframe(place.id)) {
      throw std::invalid_argument("loop closer: a place of unknown keyframe " +
                                  std::to_string(place.id));
    }
    recognizer.addSaved(std::move(place));
  }
  for (const auto& entry : jpeg_images) {
    if (!map.hasKeyframe(entry.first)) {
      throw std::invalid_argument("loop closer: an image of unknown keyframe " +
                                  std::to_string(entry.first));
    }
  }
  recognizer_ = std::move(recognizer);
  map_ = std::move(map);
  jpeg_images_ = std::move(jpeg_images);
  map_version_ = 0;
  corrections_ = map::CorrectionHistory();
}

void LoopCloser::storeKeyframe(const map::KeyframeMessage& message) {
  map::addKeyframeMessage(message, map_);
  if (!message.image.empty()) {
    // imencode grows its buffer by doubling and leaves it so (up to twice the JPEG's size): each
    // stored image gets a buffer of exactly its size, the scratch buffer is reused. Progressive
    // JPEG: 3 % smaller than baseline at the same pixels.
    cv::imencode(
        ".jpg", message.image, jpeg_scratch_,
        {cv::IMWRITE_JPEG_QUALITY, params_.image_jpeg_quality, cv::IMWRITE_JPEG_PROGRESSIVE, 1});
    jpeg_images_[message.keyframe.id].assign(jpeg_scratch_.begin(), jpeg_scratch_.end());
  }
}

cv::Mat LoopCloser::storedImage(map::KeyframeId id) const {
  const auto it = jpeg_images_.find(id);
  if (it == jpeg_images_.end()) return {};
  return cv::imdecode(it->second, cv::IMREAD_GRAYSCALE);
}

VerificationView LoopCloser::viewOf(map::KeyframeId id, const KeyframeAppearance& features,
                                    const cv::Mat& image, bool with_covisible_points) const {
  VerificationView view;
  view.features = &features;
  const map::Keyframe& keyframe = map_.keyframe(id);
  std::unordered_set<map::PointId> included;
  for (const map::Observation& o : keyframe.observations) {
    const Eigen::Vector3d p_cam = keyframe.T_kf_world * map_.point(o.point_id).p_world;
    if (p_cam.z() <= 0.0) continue;
    view.point_ids.push_back(o.point_id);
    view.point_xy.push_back(o.xyd());
    view.point_camera.push_back(p_cam);
    if (with_covisible_points) included.insert(o.point_id);  // only the neighbourhood reads it
  }
  if (with_covisible_points) {
    // The neighbourhood's points in this keyframe's view, as ORB-SLAM gathers a loop candidate's
    // neighbourhood: a keyframe keeps only the points it measured itself, and an old keyframe
    // seen from a few metres off shares few of them with the query (4 of 82 descriptor matches
    // had a depth on a rendered drive, 18 with these).
    for (const map::KeyframeId other : covisibleKeyframes(id)) {
      for (const map::Observation& o : map_.keyframe(other).observations) {
        if (!included.insert(o.point_id).second) continue;
        const Eigen::Vector3d p_cam = keyframe.T_kf_world * map_.point(o.point_id).p_world;
        if (p_cam.z() <= 0.0) continue;
        const std::optional<Eigen::Vector2d> px = camera_->project(p_cam);
        if (!px || !camera_->isInImage(*px, 0)) continue;
        view.point_ids.push_back(o.point_id);
        view.point_xy.push_back(p_cam.head<2>() / p_cam.z());
        view.point_camera.push_back(p_cam);
      }
    }
  }
  if (!image.empty()) view.image = features::buildPyramid(image, pyramid_levels_);
  return view;
}

std::unordered_set<map::KeyframeId> LoopCloser::covisibleKeyframes(map::KeyframeId id) const {
  std::unordered_map<map::KeyframeId, int> shared;
  for (const map::Observation& o : map_.keyframe(id).observations) {
    for (const map::KeyframeId other : map_.point(o.point_id).observed_by)
      ++shared[other];
  }
  std::unordered_set<map::KeyframeId> covisible;
  for (const auto& [other, count] : shared) {
    if (other != id && count >= params_.covisible_min_shared_points) covisible.insert(other);
  }
  return covisible;
}

LoopDetection LoopCloser::addKeyframe(map::KeyframeMessage message) {
  corrections_.bringUpToDate(message);
  storeKeyframe(message);
  const map::KeyframeId id = message.keyframe.id;
  LoopDetection detection;
  detection.keyframe_id = id;
  detection.recognition.query_id = id;
  if (message.image.empty()) {
    detection.recognition.skip_reason = "the keyframe carries no image";
    return detection;
  }
  const common::Stopwatch timer;
  KeyframeAppearance features = extractor_.extract(message.image, camera_.get());
  if (params_.enabled) {
    const common::Stopwatch query_timer;
    const double cpu_start = common::threadCpuMs();
    detection.recognition =
        recognizer_.query(id, message.keyframe.timestamp, features, covisibleKeyframes(id));
    detection.query_cpu_ms = common::threadCpuMs() - cpu_start;
    detection.query_ms = query_timer.ms();
  } else {
    detection.recognition.skip_reason = "loop closure disabled";
  }
  detection.recognition_ms = timer.ms();
  if (const LoopCandidate* candidate = detection.recognition.accepted()) {
    const common::Stopwatch verify_timer;
    const map::KeyframeId loop_id = candidate->keyframe_id;
    const VerificationView current = viewOf(id, features, message.image);
    const VerificationView loop = viewOf(loop_id, recognizer_.appearance(loop_id),
                                         storedImage(loop_id), /*with_covisible_points=*/true);
    LoopVerification verification = verifyLoop(current, loop, candidate->geometry.inlier_matches,
                                               *camera_, params_.verification);
    verification.constraint.current_id = id;
    verification.constraint.loop_id = loop_id;
    if (verification.success) {
      detection.constraint = verification.constraint;
    } else {
      recognizer_.reportLoopRejected(id);
    }
    detection.verification = std::move(verification);
    detection.verification_ms = verify_timer.ms();
  }
  recognizer_.add(id, message.keyframe.timestamp, std::move(features));
  return detection;
}

void LoopCloser::applyMapUpdate(const map::MapUpdate& update) {
  if (!map::applyMapUpdate(update, map_, &map_version_)) return;
  corrections_.record(update);
  // A culled keyframe is redundant: never a loop or relocalisation candidate again.
  for (const map::KeyframeId id : update.culled_keyframes) {
    recognizer_.forget(id);
    jpeg_images_.erase(id);
  }
}

map::RelocalisationAnswer LoopCloser::relocalise(const map::RelocalisationRequest& request) {
  map::RelocalisationAnswer answer;
  answer.frame_index = request.frame_index;
  answer.timestamp = request.timestamp;
  answer.map_version = map_version_;
  if (request.image.empty()) {
    answer.reason = "the request carries no image";
    return answer;
  }
  KeyframeAppearance features;
  try {
    features = extractor_.extract(request.image, camera_.get());
  } catch (const std::invalid_argument& e) {
    answer.reason = std::string("no features: ") + e.what();
    return answer;
  }
  const std::vector<LoopCandidate> places = recognizer_.findPlaces(
      features, params_.relocalisation_candidates, params_.relocalisation_geometry);
  if (places.empty()) {
    answer.reason = recognizer_.size() == 0 ? "the map has no keyframe yet"
                                            : "no keyframe looks like this frame";
    return answer;
  }
  VerificationView current;  // a frame: no map points of its own
  current.features = &features;
  current.image = features::buildPyramid(request.image, pyramid_levels_);
  for (const LoopCandidate& place : places) {
    const std::string prefix = "keyframe " + std::to_string(place.keyframe_id) + ": ";
    if (!place.geometry.passed) {
      answer.reason += (answer.reason.empty() ? "" : "; ") + prefix + place.geometry.reason;
      continue;
    }
    const VerificationView candidate =
        viewOf(place.keyframe_id, recognizer_.appearance(place.keyframe_id),
               storedImage(place.keyframe_id));
    const LoopVerification v = verifyPose(current, candidate, place.geometry.inlier_matches,
                                          *camera_, params_.verification);
    if (!v.success) {
      answer.reason += (answer.reason.empty() ? "" : "; ") + prefix + v.reason;
      continue;
    }
    answer.success = true;
    answer.reason.clear();
    answer.keyframe_id = place.keyframe_id;
    answer.T_cam_world = v.constraint.T_current_loop * map_.keyframe(place.keyframe_id).T_kf_world;
    answer.inliers = v.constraint.num_inliers;
    for (const FoundPoint& p : v.inlier_points)
      answer.points.push_back({p.id, p.px, p.xy});
    return answer;
  }
  return answer;
}

}  // namespace scale_drift_slam::loop
