#include "scale_drift_slam/tracking/tracker.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "scale_drift_slam/common/statistics.h"
#include "scale_drift_slam/common/stopwatch.h"
#include "scale_drift_slam/map/map_update.h"

namespace scale_drift_slam::tracking {

void TrackerParams::validate() const {
  if (compress_idle_patches_after_frames < 0) {
    throw std::invalid_argument("tracker.compress_idle_patches_after_frames must be >= 0");
  }
  if (pyramid_levels < 1 || pyramid_levels > 8) {
    throw std::invalid_argument("tracker.pyramid_levels must be in [1, 8]");
  }
  if (!(min_contrast >= 0.0)) throw std::invalid_argument("tracker.min_contrast must be >= 0");
  if (!(contrast_target_range > 0.0 && contrast_target_range <= 255.0)) {
    throw std::invalid_argument("tracker.contrast_target_range must be in (0, 255]");
  }
  if (!(max_contrast_gain >= 1.0)) {
    throw std::invalid_argument("tracker.max_contrast_gain must be >= 1");
  }
  if (mono16_bit_depth != 0 && (mono16_bit_depth < 8 || mono16_bit_depth > 16)) {
    throw std::invalid_argument("tracker.mono16_bit_depth must be 0 (measured) or in [8, 16]");
  }
  if (min_inliers < 6) throw std::invalid_argument("tracker.min_inliers must be >= 6");
  if (good_inliers < min_inliers) {
    throw std::invalid_argument("tracker.good_inliers must be >= tracker.min_inliers");
  }
  if (recovery_max_descriptor_distance < 0 || recovery_max_descriptor_distance > 256) {
    throw std::invalid_argument("tracker.recovery_max_descriptor_distance must be in [0, 256]");
  }
  if (!(recovery_max_ratio > 0.0 && recovery_max_ratio <= 1.0)) {
    throw std::invalid_argument("tracker.recovery_max_ratio must be in (0, 1]");
  }
  if (!(recover_on_inlier_share_drop >= 0.0 && recover_on_inlier_share_drop <= 1.0)) {
    throw std::invalid_argument("tracker.recover_on_inlier_share_drop must be in [0, 1]");
  }
  if (!(recover_on_inlier_drop >= 0.0 && recover_on_inlier_drop <= 1.0)) {
    throw std::invalid_argument("tracker.recover_on_inlier_drop must be in [0, 1]");
  }
  if (!(keyframe_refused_matches_px >= 0.0) || !std::isfinite(keyframe_refused_matches_px)) {
    throw std::invalid_argument("tracker.keyframe_refused_matches_px must be finite and >= 0");
  }
  if (local_recent_keyframes < 1 || local_nearest_keyframes < 0 ||
      local_covisibility_min_shared < 1) {
    throw std::invalid_argument(
        "tracker.local_recent_keyframes must be >= 1, "
        "local_nearest_keyframes >= 0, local_covisibility_min_shared >= 1");
  }
  if (max_rejected_frames < 1 || relocalisation_retry_frames < 1 || restart_after_lost_frames < 1 ||
      restart_below_keyframes < 0) {
    throw std::invalid_argument(
        "tracker.max_rejected_frames, relocalisation_retry_frames and restart_after_lost_frames "
        "must be >= 1, restart_below_keyframes >= 0");
  }
  if (retire_after_searches < 1 || !(retire_found_ratio >= 0.0 && retire_found_ratio <= 1.0)) {
    throw std::invalid_argument(
        "tracker: need retire_after_searches >= 1 and retire_found_ratio in [0, 1]");
  }
  features.validate();
  initializer.validate();
  motion_prior.validate();
  search.validate();
  motion_ba.validate();
  candidates.validate();
  keyframes.validate();
  triangulation.validate();
}

std::string trackingStateName(TrackingState state) {
  switch (state) {
    case TrackingState::kInitializing:
      return "initializing";
    case TrackingState::kGood:
      return "good";
    case TrackingState::kWeak:
      return "weak";
    case TrackingState::kLost:
      return "lost";
  }
  return "unknown";
}

namespace {

/// The angle between the rays through the middles of opposite image borders, the smaller of the
/// horizontal and the vertical one (any lens model).
double narrowestFieldOfView(const geometry::CameraModel& camera) {
  const double w = camera.width() - 1.0, h = camera.height() - 1.0;
  const auto angle = [&](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    const Eigen::Vector3d ra = camera.unproject(a).normalized(),
                          rb = camera.unproject(b).normalized();
    return std::acos(std::clamp(ra.dot(rb), -1.0, 1.0));
  };
  return std::min(angle({0.0, h / 2}, {w, h / 2}), angle({w / 2, 0.0}, {w / 2, h}));
}

}  // namespace

Tracker::Tracker(std::shared_ptr<const geometry::CameraModel> camera, const TrackerParams& params)
    : camera_(std::move(camera)),
      frame_camera_(camera_),
      params_(params),
      focal_(camera_ ? camera_->calibration().meanFocalLength() : 0.0),
      field_of_view_(camera_ ? narrowestFieldOfView(*camera_) : 0.0),
      initializer_(camera_, params.initializer, params.features, params.motion_prior.flow),
      motion_prior_(params.motion_prior, params.motion_ba),
      candidates_(params.candidates, params.features, focal_),
      triangulation_(params.triangulation, params.features, focal_) {
  params_.validate();
}

FrameResult Tracker::processFrame(double timestamp, const cv::Mat& image,
                                  features::PixelEncoding encoding) {
  common::Stopwatch total, stage;
  const double cpu_start = common::threadCpuMs();
  // The keyframe dropped at the previous frame first, as it would have been finished there.
  finishPendingKeyframe();
  const double finishing_ms = stage.lapMs();  // counted as keyframe work, not as preparation
  FrameResult result;
  result.keyframes = std::exchange(finished_keyframes_, {});
  result.times.keyframe_worker_cpu = std::exchange(worker_cpu_ms_, 0.0);
  result.timestamp = timestamp;
  result.state = state_;
  result.loop_correction = pending_loop_correction_;
  pending_loop_correction_.reset();
  ++frame_index_;
  cv::Mat grey;
  try {
    if (encoding == features::PixelEncoding::kMono16 && image.type() == CV_16UC1) {
      mono16_bits_ = params_.mono16_bit_depth > 0
                         ? params_.mono16_bit_depth
                         : std::max(mono16_bits_, features::significantBits(image));
    }
    grey = features::toGrey(image, encoding, mono16_bits_ > 0 ? mono16_bits_ : 16);
  } catch (const std::invalid_argument& e) {
    rejectFrame(e.what(), &result);
    startNextMapAfterYoungMapLost(&result);
    return result;
  }
  // Stretch a dark or washed-out frame before anything looks at it (doc/frontend.md, step 1);
  // black and uniform frames stay as they are and are rejected below.
  features::stretchContrast(&grey, params_.contrast_target_range, params_.max_contrast_gain);
  const std::string problem =
      features::frameProblem(grey, camera_->width(), camera_->height(), params_.min_contrast);
  if (!problem.empty()) {
    rejectFrame(problem, &result);
    startNextMapAfterYoungMapLost(&result);
    return result;
  }
  rejected_in_row_ = 0;
  const features::ImagePyramid pyramid = features::buildPyramid(
      grey, params_.pyramid_levels,
      std::max(params_.motion_prior.flow.window, params_.motion_prior.candidate_flow_window),
      params_.motion_prior.flow.photometric_radius);
  result.times.prepare = stage.lapMs();
  try {
    if (state_ == TrackingState::kInitializing) {
      initialise(timestamp, pyramid, &result);
    } else if (awaiting_first_relocalisation_) {
      result.message = "lost: waiting for relocalisation in the loaded map";
    } else {
      track(timestamp, pyramid, &result);
    }
  } catch (const cv::Exception& e) {
    // An image OpenCV cannot process must not end the run: report it, keep the state (and the
    // loop correction to report, which was taken from pending_loop_correction_ already).
    // Keyframes already made stay reported: the map holds them and the mapper must get them.
    const std::optional<geometry::Sim3> loop_correction = result.loop_correction;
    std::vector<map::KeyframeMessage> keyframes = std::move(result.keyframes);
    result = FrameResult{};
    result.loop_correction = loop_correction;
    result.keyframes = std::move(keyframes);
    result.timestamp = timestamp;
    result.rejected = true;
    result.message = std::string("frame rejected: OpenCV failed: ") + e.what();
  }
  if (state_ == TrackingState::kLost && !result.rejected) {
    requestRelocalisation(timestamp, pyramid, &result);
    if (initialising_next_map_) {
      try {
        initialiseNextMap(timestamp, pyramid, &result);
      } catch (const cv::Exception& e) {  // as for initialise: the frame is reported, not fatal
        result.message += std::string("; new map: OpenCV failed: ") + e.what();
      }
    }
  }
  startNextMapAfterYoungMapLost(&result);
  if (result.has_pose && next_keyframe_id_ > 0) result.reference_keyframe = next_keyframe_id_ - 1;
  result.state = state_;
  if (result.has_pose) {
    for (const Measurement& m : previous_measurements_)
      result.tracked_px.push_back(m.px);
  }
  if (!keyframe_problem_.empty()) {
    result.message += (result.message.empty() ? "" : "; ") + std::exchange(keyframe_problem_, {});
  }
  result.times.keyframe += finishing_ms;
  result.times.total = total.lapMs();
  result.times.cpu = common::threadCpuMs() - cpu_start;
  return result;
}

void Tracker::rejectFrame(const std::string& reason, FrameResult* result) {
  result->rejected = true;
  result->message = "frame rejected: " + reason;
  const bool tracking = state_ == TrackingState::kGood || state_ == TrackingState::kWeak;
  if (tracking && ++rejected_in_row_ >= params_.max_rejected_frames) {
    // The camera moved on unseen: the motion prior has nothing to go on any more.
    state_ = TrackingState::kLost;
    previous_measurements_.clear();
    result->message += "; lost after " + std::to_string(rejected_in_row_) + " unusable frames";
  }
  result->state = state_;
}

void Tracker::startNextMapAfterYoungMapLost(FrameResult* result) {
  if (state_ != TrackingState::kLost) {
    lost_in_row_ = 0;
    initialising_next_map_ = false;  // found again (or a new map started)
    return;
  }
  ++lost_in_row_;
  const std::size_t keyframes = map_.numKeyframes();
  if (initialising_next_map_ || restored_map_ || lost_in_row_ < params_.restart_after_lost_frames ||
      keyframes >= static_cast<std::size_t>(params_.restart_below_keyframes)) {
    return;
  }
  // The young map is kept until a new one starts: if none does (the camera sees nothing usable
  // again), the young map's poses are the ones the run keeps.
  initialising_next_map_ = true;
  initializer_.reset();
  result->message += (result->message.empty() ? "" : "; ") + std::string("lost for ") +
                     std::to_string(params_.restart_after_lost_frames) + " frames with a map of " +
                     std::to_string(keyframes) +
                     " keyframes (too young to relocalise in): initialising a new map, the young "
                     "map kept until it starts";
}

void Tracker::initialiseNextMap(double timestamp, const features::ImagePyramid& frame,
                                FrameResult* result) {
  std::optional<InitialMap> initial = initializer_.addFrame(timestamp, frame);
  if (!initial) {
    result->message +=
        (result->message.empty() ? "" : "; ") + std::string("new map: ") + initializer_.status();
    return;
  }
  const std::string message = "the young map (" + std::to_string(map_.numKeyframes()) +
                              " keyframes, lost for " + std::to_string(lost_in_row_) +
                              " frames) discarded: " + initializer_.status();
  // A fresh tracker: nothing of the young map may leak into the next one. Only the frame
  // counter goes on (relocalisation answers are matched by it).
  const std::uint64_t frame_index = frame_index_;
  finishPendingKeyframe();  // none (finished at the frame's start): no worker may outlive this
  *this = Tracker(camera_, params_);
  frame_index_ = frame_index;
  result->map_restarted = true;
  result->relocalisation_request.reset();
  result->keyframes.clear();  // the young map's, if any: its receivers drop it anyway
  result->loop_correction.reset();
  result->message = message;
  startMap(*initial, timestamp, frame, result);
}

void Tracker::requestRelocalisation(double timestamp, const features::ImagePyramid& image,
                                    FrameResult* result) {
  if (relocalisation_ && frame_index_ - relocalisation_->frame_index <
                             static_cast<std::uint64_t>(params_.relocalisation_retry_frames)) {
    relocalisation_->frames.push_back(image);  // one request at a time; keep the frames since
    return;
  }
  relocalisation_ = PendingRelocalisation{frame_index_, {image}};
  map::RelocalisationRequest request;
  request.frame_index = frame_index_;
  request.timestamp = timestamp;
  request.map_version = map_.version();
  request.image = image.base().clone();
  result->relocalisation_request = std::move(request);
}

bool Tracker::applyRelocalisation(const map::RelocalisationAnswer& answer) {
  finishPendingKeyframe();
  if (!relocalisation_ || answer.frame_index != relocalisation_->frame_index) return false;
  const PendingRelocalisation pending = std::move(*relocalisation_);
  relocalisation_.reset();
  // Useless when it failed, when tracking recovered meanwhile, or when the answer's world frame
  // predates a loop correction the tracker has applied since.
  if (!answer.success || state_ != TrackingState::kLost) return false;
  if (answer.map_version < last_loop_version_) return false;
  std::vector<map::PointId> ids;
  std::vector<FlowSeed> seeds;
  for (const map::RelocalisationAnswer::FoundPoint& p : answer.points) {
    if (!map_.hasPoint(p.id)) continue;
    ids.push_back(p.id);
    seeds.push_back({cv::Point2f(static_cast<float>(p.px.x()), static_cast<float>(p.px.y())),
                     map_.point(p.id).p_world});
  }
  // The answer is about the requested frame; the camera has moved on since: carry the found
  // points through the frames seen meanwhile to the last one, and track on from there.
  const std::optional<MotionPriorEstimator::Carried> carried =
      motion_prior_.carry(pending.frames, seeds, answer.T_cam_world, *camera_);
  if (!carried || static_cast<int>(carried->px.size()) < params_.min_inliers) return false;
  previous_measurements_.clear();
  for (std::size_t i = 0; i < carried->px.size(); ++i) {
    const Eigen::Vector2d px(carried->px[i].x, carried->px[i].y);
    previous_measurements_.push_back(
        {ids[carried->seed[i]], px, camera_->undistortToNormalized(px)});
  }
  // The feature candidates followed the flow through the lost frames (track()), so their pixels
  // are in this last frame too and they are kept.
  previous_image_ = pending.frames.back();
  awaiting_first_relocalisation_ = false;
  T_previous_world_ = T_before_previous_world_ = carried->T_cam_world;
  last_scene_depth_ = sceneDepth(carried->T_cam_world);
  resume_from_relocalisation_ = true;
  return true;
}

void Tracker::restoreMap(
    const map::Map& map,
    const std::unordered_map<map::PointId, features::PointAppearance>& appearances,
    const std::vector<std::pair<map::KeyframeId, map::KeyframeId>>& loop_links) {
  if (state_ != TrackingState::kInitializing || frame_index_ != 0 || map_.numKeyframes() != 0) {
    throw std::logic_error("tracker: a map can only be restored before the first frame");
  }
  if (map.numKeyframes() == 0) throw std::invalid_argument("tracker: the map has no keyframe");
  TrackingMap restored;
  for (const auto& [id, point] : map.points()) {
    const auto appearance = appearances.find(id);
    if (appearance == appearances.end() || appearance->second.empty()) continue;
    TrackedPoint tracked;
    tracked.id = id;
    tracked.p_world = point.p_world;
    tracked.reference_keyframe = point.reference_keyframe;
    tracked.appearance = appearance->second;
    restored.addPoint(std::move(tracked));
    next_point_id_ = std::max(next_point_id_, id + 1);
  }
  for (const auto& [id, keyframe] : map.keyframes()) {
    TrackedKeyframe tracked{id, keyframe.timestamp, keyframe.T_kf_world, {}};
    for (const map::Observation& o : keyframe.observations) {
      if (restored.hasPoint(o.point_id)) tracked.points.push_back(o.point_id);
    }
    restored.addKeyframe(std::move(tracked));
    next_keyframe_id_ = std::max(next_keyframe_id_, id + 1);
  }
  for (const auto& [id, point] : map.points())
    next_point_id_ = std::max(next_point_id_, id + 1);
  for (const auto& [a, b] : loop_links) {
    if (restored.hasKeyframe(a) && restored.hasKeyframe(b)) restored.linkKeyframes(a, b);
  }
  map_ = std::move(restored);
  state_ = TrackingState::kLost;
  awaiting_first_relocalisation_ = true;
  restored_map_ = true;
}

void Tracker::applyMapUpdate(const map::MapUpdate& update) {
  finishPendingKeyframe();  // made before this update: it must ride with it like the others
  // A bundle adjustment moved keyframes up to N while this tracker went on from newer ones (the
  // mapper or the link behind, an outage): those, their points and the camera ride with N.
  const std::optional<TrackingMap::TailCorrection> tail = map_.tailCorrection(update);
  if (!map_.apply(update)) return;
  candidates_.apply(update);
  if (tail) {
    map_.moveTail(*tail);
    candidates_.moveTail(tail->anchor, tail->C_new_old);
    const geometry::SE3 C_old_new = tail->C_new_old.inverse();
    T_previous_world_ = T_previous_world_ * C_old_new;
    T_before_previous_world_ = T_before_previous_world_ * C_old_new;
  }
  if (!update.S_new_old) return;
  // A loop correction: the camera moves with the newest keyframe.
  const geometry::Sim3& S = *update.S_new_old;
  T_previous_world_ = map::correctPose(T_previous_world_, S);
  T_before_previous_world_ = map::correctPose(T_before_previous_world_, S);
  last_scene_depth_ *= S.scale();
  pending_loop_correction_ = pending_loop_correction_ ? S * *pending_loop_correction_ : S;
  last_loop_version_ = update.map_version;
}

map::PointId Tracker::addNewPoint(const Eigen::Vector3d& p_world,
                                  map::KeyframeId reference_keyframe,
                                  features::PointAppearance appearance,
                                  map::KeyframeMessage* message) {
  TrackedPoint point;
  point.id = next_point_id_++;
  point.p_world = p_world;
  point.reference_keyframe = reference_keyframe;
  point.appearance = std::move(appearance);
  point.last_selected_frame = frame_index_;  // new: not idle
  message->new_points.push_back({point.id, p_world, reference_keyframe});
  map_.addPoint(std::move(point));
  return next_point_id_ - 1;
}

map::KeyframeMessage Tracker::makeKeyframe(double timestamp, const geometry::SE3& T_kf_world,
                                           const features::ImagePyramid& image) {
  map::KeyframeMessage message;
  message.keyframe.id = next_keyframe_id_++;
  message.keyframe.timestamp = timestamp;
  message.keyframe.T_kf_world = T_kf_world;
  message.image = image.base().clone();
  message.map_version = map_.version();
  return message;
}

void Tracker::initialise(double timestamp, const features::ImagePyramid& image,
                         FrameResult* result) {
  std::optional<InitialMap> initial = initializer_.addFrame(timestamp, image);
  result->message = initializer_.status();
  if (initial) startMap(*initial, timestamp, image, result);
}

void Tracker::startMap(const InitialMap& initial, double timestamp,
                       const features::ImagePyramid& image, FrameResult* result) {
  // The second view's free corners and new features are measured as the initializer measured
  // the view (a rolling shutter turning at its tracks' rate).
  frame_camera_ = initial.second_camera ? initial.second_camera : camera_;
  map::KeyframeMessage first =
      makeKeyframe(initial.first_timestamp, geometry::SE3(), initial.first_image);
  map::KeyframeMessage second = makeKeyframe(timestamp, initial.T_second_first, image);
  TrackedKeyframe first_kf{
      first.keyframe.id, first.keyframe.timestamp, first.keyframe.T_kf_world, {}, next_point_id_};
  TrackedKeyframe second_kf{
      second.keyframe.id, timestamp, second.keyframe.T_kf_world, {}, next_point_id_};
  previous_measurements_.clear();
  std::vector<Eigen::Vector2d> occupied;
  for (std::size_t i = 0; i < initial.p_first.size(); ++i) {
    if (!initial.triangulated[i]) continue;
    features::PointAppearance appearance;
    if (!appearance.cut(initial.first_image, initial.px_first[i])) continue;
    const map::PointId id =
        addNewPoint(initial.p_first[i], first.keyframe.id, std::move(appearance), &first);
    first.keyframe.observations.push_back({id, initial.xy_first[i]});
    second.keyframe.observations.push_back({id, initial.xy_second[i]});
    first_kf.points.push_back(id);
    second_kf.points.push_back(id);
    previous_measurements_.push_back({id, initial.px_second[i], initial.xy_second[i]});
    occupied.push_back(initial.px_second[i]);
  }
  map_.addKeyframe(std::move(first_kf));
  map_.addKeyframe(std::move(second_kf));
  tracked_at_keyframe_ = static_cast<int>(previous_measurements_.size());
  state_ = TrackingState::kGood;
  T_previous_world_ = T_before_previous_world_ = initial.T_second_first;
  previous_image_ = image;
  previous_timestamp_ = timestamp;
  last_scene_depth_ = sceneDepth(initial.T_second_first);
  result->has_pose = true;
  result->T_cam_world = initial.T_second_first;
  result->num_inliers = static_cast<int>(previous_measurements_.size());
  result->keyframes.push_back(std::move(first));
  // The second keyframe's free corners wait for the next keyframe to be matched with (nothing to
  // match yet, so no worker): both keyframes are reported with this frame.
  triangulateKeyframe(PendingKeyframe{std::move(second), image, std::move(occupied), {}},
                      /*in_worker=*/false, result);
}

double Tracker::sceneDepth(const geometry::SE3& T_cam_world) const {
  std::vector<double> depths;
  for (const Measurement& m : previous_measurements_) {
    const double z = map_.hasPoint(m.id) ? (T_cam_world * map_.point(m.id).p_world).z() : -1.0;
    if (z > 0.0) depths.push_back(z);
  }
  return depths.empty() ? last_scene_depth_ : common::upperMedian(std::move(depths));
}

std::string Tracker::describeMono16BitDepth() const {
  return "16-bit images are read as " + std::to_string(mono16_bits_) + "-bit data (scaled by 1/" +
         std::to_string(1 << (mono16_bits_ - 8)) +
         (params_.mono16_bit_depth > 0
              ? ", tracker.mono16_bit_depth)"
              : ", from the largest value so far; set tracker.mono16_bit_depth or --bit-depth to "
                "fix it)");
}

}  // namespace scale_drift_slam::tracking
