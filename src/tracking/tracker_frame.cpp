// Tracker: tracking one frame and dropping keyframes (the rest is in tracker.cpp).

#include <algorithm>
#include <chrono>
#include <cmath>
#include <future>
#include <unordered_map>
#include <unordered_set>
#include <utility>

#include "scale_drift_slam/common/stopwatch.h"
#include "scale_drift_slam/geometry/rolling_shutter_camera.h"
#include "scale_drift_slam/geometry/so3.h"
#include "scale_drift_slam/tracking/tracker.h"

namespace scale_drift_slam::tracking {
namespace {

/// The share of inliers among the points found (0 when none was found).
double inlierShare(const FrameResult& result) {
  const int found = std::max(result.num_found, result.num_inliers);
  return found > 0 ? static_cast<double>(result.num_inliers) / found : 0.0;
}

/// The camera that measures a frame taken while the camera moved by T_cur_prev in `interval`
/// seconds (geometry::frameCamera): `camera` itself for a global shutter or without a positive
/// interval.
std::shared_ptr<const geometry::CameraModel> movingCamera(
    const std::shared_ptr<const geometry::CameraModel>& camera, const geometry::SE3& T_cur_prev,
    double interval, double scene_depth) {
  if (!(interval > 0.0)) return camera;
  return geometry::frameCamera(camera, geometry::logSO3(T_cur_prev.rotation()) / interval,
                               T_cur_prev.translation() / interval, scene_depth);
}

}  // namespace

void Tracker::track(double timestamp, const features::ImagePyramid& image, FrameResult* result) {
  common::Stopwatch stage;
  // 1. Motion prior: flow from the previous frame (its map points and the feature candidates).
  // A rolling shutter's rows are measured from the camera turning as the constant-velocity
  // model says, then as the prior says (nothing to do for a global shutter: frame_camera_ is
  // camera_).
  const double frame_interval = timestamp - previous_timestamp_;
  frame_camera_ = movingCamera(camera_,
                               state_ == TrackingState::kLost
                                   ? geometry::SE3()
                                   : T_previous_world_ * T_before_previous_world_.inverse(),
                               frame_interval, last_scene_depth_);
  std::vector<cv::Point2f> candidate_px;
  std::vector<unsigned char> candidate_ok;
  const MotionPrior prior = estimatePrior(image, &candidate_px, &candidate_ok);
  if (prior.from_flow) {
    frame_camera_ = movingCamera(camera_, prior.T_cur_world * T_previous_world_.inverse(),
                                 frame_interval, last_scene_depth_);
  }
  result->times.flow = stage.lapMs();
  // 2-3. Active search for the local map points around the prior.
  std::vector<map::PointId> ids;
  const std::vector<features::SearchPoint> search_points = localSearchPoints(prior, &ids);
  const features::CornerGrid corners = features::detectSearchCorners(image, params_.search);
  std::vector<features::SearchMatch> matches =
      features::activeSearch(search_points, prior.T_cur_world, prior.Sigma, *frame_camera_, image,
                             corners, params_.search);
  result->times.search = stage.lapMs();
  // 4. Motion-only BA on the matches (pseudo-Huber), starting at the prior.
  std::vector<Measurement> inliers;
  geometry::SE3 T_cam_world = solvePose(prior.T_cur_world, ids, matches, &inliers, result);
  // 4b. The points missed around the prior, searched again around the pose: the prior rests on
  // the flow of the points tracked in the previous frame, which in a fast pan crowd into the
  // image side the view is leaving, and its error on the other side, where the newest points
  // are, can exceed its gate (found 65 of 249 visible right after a keyframe promoted 192).
  if (result->num_inliers >= params_.min_inliers) {
    researchMissed(T_cam_world, ids, search_points, image, corners, &matches, &inliers,
                   &T_cam_world, result);
  }
  // Few inliers, a share of inliers among the points found fallen far below its recent average
  // (a pose from a wrong prior, points matched onto the wrong texture: the share is ~0.95 on
  // renders, 0.5-0.7 on real images, and a wrong pose halves it), or far fewer inliers than the
  // frame before: the frame is tried again from the newest keyframe's points.
  const bool share_dropped =
      inlier_share_average_ > 0.0 &&
      inlierShare(*result) < params_.recover_on_inlier_share_drop * inlier_share_average_;
  const bool inliers_dropped =
      result->num_inliers <
      params_.recover_on_inlier_drop * static_cast<double>(previous_measurements_.size());
  if (params_.recover_from_keyframe &&
      (result->num_inliers < params_.good_inliers || share_dropped || inliers_dropped)) {
    recoverFromKeyframe(image, corners, ids, search_points, &matches, &inliers, &T_cam_world,
                        result);
  }
  recordSearches(ids, matches, result);
  result->times.motion_ba = stage.lapMs();

  previous_image_ = image;
  previous_timestamp_ = timestamp;
  const bool from_relocalisation = resume_from_relocalisation_;
  resume_from_relocalisation_ = false;
  if (result->num_inliers < params_.min_inliers) {
    // Lost: say so, keep the last pose, add no keyframe. The filters cannot be updated without
    // a pose, but their pixels follow the flow into this image (the next flow starts from it).
    candidates_.follow(candidate_px, candidate_ok, *frame_camera_);
    state_ = TrackingState::kLost;
    previous_measurements_.clear();
    result->message = "lost: " + std::to_string(result->num_inliers) + " inliers of " +
                      std::to_string(result->num_found) + " matches";
    return;
  }
  const bool was_lost = state_ == TrackingState::kLost;
  if (was_lost) {
    result->relocalised = from_relocalisation;
    result->message = from_relocalisation ? "relocalised" : "recovered";
    // A request still pending is void: its frames end here, and a later loss starts a new one
    // (appending to it would leave a gap of tracked frames for the answer to be carried across).
    relocalisation_.reset();
  }
  state_ =
      result->num_inliers >= params_.good_inliers ? TrackingState::kGood : TrackingState::kWeak;
  // The constant-velocity model: after recovering by itself the last pose is frames old (no
  // velocity to keep); after relocalisation the carried pose is the previous frame's.
  T_before_previous_world_ = was_lost && !from_relocalisation ? T_cam_world : T_previous_world_;
  T_previous_world_ = T_cam_world;
  previous_measurements_ = inliers;
  last_scene_depth_ = sceneDepth(T_cam_world);
  const double share = inlierShare(*result);
  inlier_share_average_ =
      inlier_share_average_ > 0.0 ? 0.8 * inlier_share_average_ + 0.2 * share : share;
  result->has_pose = true;
  result->T_cam_world = T_cam_world;
  // 5. Inverse-depth filters of the new features, with the flow's measurements.
  candidates_.update(candidate_px, candidate_ok, T_cam_world, *frame_camera_);
  result->times.filters = stage.lapMs();
  // 6. The keyframe rule (tracking is good or weak here, not lost); none when only localising.
  if (localization_only_) return;
  const ViewDirections view{T_cam_world.rotation().conjugate() * Eigen::Vector3d::UnitZ(),
                            map_.keyframeViewAxes(), field_of_view_};
  TrackedPoints tracked{result->num_inliers, tracked_at_keyframe_, candidates_.numCertain(), {}};
  tracked.points_world.reserve(inliers.size());
  for (const Measurement& m : inliers)
    tracked.points_world.push_back(map_.point(m.id).p_world);
  const KeyframeDecision decision =
      decideKeyframe(T_cam_world.inverseTranslation(), map_.keyframeCentres(), last_scene_depth_,
                     params_.keyframes, tracked, view);
  if (decision.drop) {
    dropKeyframe(timestamp, image, inliers, refusedMatches(T_cam_world, ids, matches, inliers),
                 result);
    if (result->message.empty()) result->message = keyframeReason(decision);
  }
  result->times.keyframe = stage.lapMs();
}

MotionPrior Tracker::estimatePrior(const features::ImagePyramid& image,
                                   std::vector<cv::Point2f>* candidate_px,
                                   std::vector<unsigned char>* candidate_ok) {
  const geometry::SE3 velocity = T_previous_world_ * T_before_previous_world_.inverse();
  const geometry::SE3 T_guess =
      state_ == TrackingState::kLost ? T_previous_world_ : velocity * T_previous_world_;
  std::vector<FlowSeed> seeds;
  for (const Measurement& m : previous_measurements_) {
    if (map_.hasPoint(m.id)) {
      seeds.push_back({cv::Point2f(static_cast<float>(m.px.x()), static_cast<float>(m.px.y())),
                       map_.point(m.id).p_world});
    }
  }
  return motion_prior_.estimate(previous_image_, image, seeds, candidates_.pixels(), T_guess,
                                T_previous_world_, last_scene_depth_, *frame_camera_, candidate_px,
                                candidate_ok);
}

std::vector<features::SearchPoint> Tracker::localSearchPoints(const MotionPrior& prior,
                                                              std::vector<map::PointId>* ids) {
  std::vector<map::PointId> tracked;
  tracked.reserve(previous_measurements_.size());
  for (const Measurement& m : previous_measurements_)
    tracked.push_back(m.id);
  *ids = map_.localPoints(prior.T_cur_world.inverseTranslation(), params_.local_recent_keyframes,
                          params_.local_nearest_keyframes, tracked,
                          params_.local_covisibility_min_shared, frame_index_);
  std::vector<features::SearchPoint> search_points;
  search_points.reserve(ids->size());
  for (const map::PointId id : *ids) {
    const TrackedPoint& point = map_.point(id);
    // A point that active search keeps failing on (occluded, on an edge, moving) is retired.
    if (point.times_searched >= params_.retire_after_searches &&
        point.times_found < params_.retire_found_ratio * point.times_searched) {
      search_points.push_back({point.p_world, geometry::SE3(), nullptr});
      continue;
    }
    const geometry::SE3 T_ref_world = map_.hasKeyframe(point.reference_keyframe)
                                          ? map_.keyframe(point.reference_keyframe).T_kf_world
                                          : geometry::SE3();
    search_points.push_back({point.p_world, T_ref_world, &point.appearance});
  }
  return search_points;
}

void Tracker::researchMissed(const geometry::SE3& T_cam_world, const std::vector<map::PointId>& ids,
                             const std::vector<features::SearchPoint>& search_points,
                             const features::ImagePyramid& image,
                             const features::CornerGrid& corners,
                             std::vector<features::SearchMatch>* matches,
                             std::vector<Measurement>* inliers, geometry::SE3* T_solved,
                             FrameResult* result) {
  std::vector<std::size_t> missed;
  std::vector<features::SearchPoint> again;
  for (std::size_t i = 0; i < matches->size(); ++i) {
    if ((*matches)[i].searched && !(*matches)[i].found) {
      missed.push_back(i);
      again.push_back(search_points[i]);
    }
  }
  if (missed.empty()) return;
  // Around the solved pose the uncertainty is that of the prior's floor.
  const double depth = last_scene_depth_ > 0.0 ? last_scene_depth_ : 1.0;
  Eigen::Matrix<double, 6, 1> d;
  d << Eigen::Vector3d::Constant(std::pow(params_.motion_prior.min_rotation_sigma, 2)),
      Eigen::Vector3d::Constant(std::pow(params_.motion_prior.min_translation_sigma * depth, 2));
  const std::vector<features::SearchMatch> found_again = features::activeSearch(
      again, T_cam_world, d.asDiagonal(), *frame_camera_, image, corners, params_.search);
  int recovered = 0;
  for (std::size_t k = 0; k < missed.size(); ++k) {
    if (!found_again[k].found) continue;
    (*matches)[missed[k]] = found_again[k];
    ++recovered;
  }
  if (recovered == 0) return;
  std::vector<Measurement> more_inliers;
  FrameResult counts;
  const geometry::SE3 T = solvePose(T_cam_world, ids, *matches, &more_inliers, &counts);
  if (counts.num_inliers <= result->num_inliers) return;
  *T_solved = T;
  *inliers = std::move(more_inliers);
  result->num_found = counts.num_found;
  result->num_inliers = counts.num_inliers;
  result->pose_information = counts.pose_information;
}

void Tracker::recordSearches(const std::vector<map::PointId>& ids,
                             const std::vector<features::SearchMatch>& matches,
                             FrameResult* result) {
  for (std::size_t i = 0; i < matches.size(); ++i) {
    TrackedPoint& point = map_.point(ids[i]);
    point.times_searched += matches[i].searched;
    point.times_found += matches[i].found;
    result->num_visible += matches[i].visible;
  }
}

geometry::SE3 Tracker::solvePose(const geometry::SE3& T_guess, const std::vector<map::PointId>& ids,
                                 const std::vector<features::SearchMatch>& matches,
                                 std::vector<Measurement>* inliers, FrameResult* result) {
  features::MotionOnlyInput input;
  input.T_cam_world_guess = T_guess;
  input.focal_length_px = focal_;
  std::vector<std::size_t> used;
  for (std::size_t i = 0; i < matches.size(); ++i) {
    if (!matches[i].found) continue;
    input.observations.push_back({map_.point(ids[i]).p_world, matches[i].xy});
    used.push_back(i);
  }
  result->num_found = static_cast<int>(used.size());
  result->num_inliers = 0;
  if (result->num_found < params_.min_inliers) return T_guess;
  const features::MotionOnlyResult solved =
      features::solveMotionOnlyBundleAdjustment(input, params_.motion_ba);
  for (std::size_t k = 0; k < used.size(); ++k) {
    const features::SearchMatch& match = matches[used[k]];
    if (solved.inlier[k]) inliers->push_back({ids[used[k]], match.px, match.xy});
  }
  result->num_inliers = static_cast<int>(inliers->size());
  result->pose_information = solved.inlier_information;
  return solved.T_cam_world;
}

std::vector<Tracker::Measurement> Tracker::refusedMatches(
    const geometry::SE3& T_cam_world, const std::vector<map::PointId>& ids,
    const std::vector<features::SearchMatch>& matches,
    const std::vector<Measurement>& inliers) const {
  std::vector<Measurement> refused;
  const double max_px = params_.keyframe_refused_matches_px;
  if (max_px <= 0.0) return refused;
  std::unordered_set<map::PointId> accepted;
  for (const Measurement& m : inliers)
    accepted.insert(m.id);
  for (std::size_t i = 0; i < matches.size(); ++i) {
    if (!matches[i].found || accepted.count(ids[i]) || !map_.hasPoint(ids[i])) continue;
    const std::optional<Eigen::Vector2d> px =
        frame_camera_->project(T_cam_world * map_.point(ids[i]).p_world);
    if (px && (*px - matches[i].px).norm() < max_px)
      refused.push_back({ids[i], matches[i].px, matches[i].xy});
  }
  return refused;
}

void Tracker::dropKeyframe(double timestamp, const features::ImagePyramid& image,
                           const std::vector<Measurement>& inliers,
                           const std::vector<Measurement>& refused, FrameResult* result) {
  const geometry::SE3& T_kf_world = T_previous_world_;
  map::KeyframeMessage message = makeKeyframe(timestamp, T_kf_world, image);
  const map::KeyframeId kf_id = message.keyframe.id;
  TrackedKeyframe tracked{kf_id, timestamp, T_kf_world, {}, next_point_id_};
  std::vector<Eigen::Vector2d> occupied;
  for (const Measurement& m : inliers) {
    message.keyframe.observations.push_back({m.id, m.xy});
    tracked.points.push_back(m.id);
    occupied.push_back(m.px);
  }
  // Observations for the mapper's BA only: the tracker keeps refusing these points until the BA
  // has moved them.
  for (const Measurement& m : refused) {
    message.keyframe.observations.push_back({m.id, m.xy});
    occupied.push_back(m.px);
  }
  map_.addKeyframe(std::move(tracked));
  for (PromotedFeature& feature : candidates_.promote(kf_id, T_kf_world)) {
    const map::PointId id =
        addNewPoint(feature.p_world, feature.origin, std::move(feature.appearance), &message);
    for (const PromotionView& view : feature.views) {
      if (view.keyframe_id == kf_id) {
        message.keyframe.observations.push_back({id, view.xy});
      } else {
        message.earlier_observations.push_back({view.keyframe_id, id, view.xy});
      }
      map_.linkPoint(view.keyframe_id, id);
    }
    if (const auto px = frame_camera_->project(T_kf_world * feature.p_world))
      occupied.push_back(*px);
  }
  triangulateKeyframe(PendingKeyframe{std::move(message), image, std::move(occupied), {}},
                      params_.keyframe_worker, result);
}

void Tracker::triangulateKeyframe(PendingKeyframe pending, bool in_worker, FrameResult* result) {
  // The candidates' corners stay theirs: their filters will promote them.
  std::vector<Eigen::Vector2d> taken = pending.occupied;
  for (const cv::Point2f& px : candidates_.pixels())
    taken.emplace_back(px.x, px.y);
  // The worker reads copies only (and triangulation_, which nothing else touches meanwhile):
  // the poses of the keyframes it matches with as they are now.
  std::unordered_map<map::KeyframeId, geometry::SE3> poses;
  for (const map::KeyframeId id : triangulation_.neighbourIds()) {
    if (map_.hasKeyframe(id)) poses.emplace(id, map_.keyframe(id).T_kf_world);
  }
  auto triangulate = [triangulation = &triangulation_, id = pending.message.keyframe.id,
                      T_kf_world = pending.message.keyframe.T_kf_world, image = pending.image,
                      taken = std::move(taken), camera = frame_camera_,
                      poses = std::move(poses)]() {
    const auto pose_of = [&poses](map::KeyframeId other) -> std::optional<geometry::SE3> {
      const auto it = poses.find(other);
      if (it == poses.end()) return std::nullopt;
      return it->second;
    };
    return triangulation->addKeyframe(id, T_kf_world, image, taken, *camera, pose_of);
  };
  if (in_worker) {
    pending.triangulated = std::async(std::launch::async, [triangulate = std::move(triangulate)]() {
      const double cpu_start = common::threadCpuMs();
      std::vector<TriangulatedPoint> points = triangulate();
      return WorkerOutput{std::move(points), common::threadCpuMs() - cpu_start};
    });
    pending_keyframe_ = std::move(pending);
    return;
  }
  std::promise<WorkerOutput> now;  // its CPU time is the frame's own
  try {
    now.set_value(WorkerOutput{triangulate(), 0.0});
  } catch (const std::exception&) {
    now.set_exception(std::current_exception());  // handled as from the worker
  }
  pending.triangulated = now.get_future();
  completeKeyframe(std::move(pending), &result->keyframes);
}

void Tracker::completeKeyframe(PendingKeyframe pending, std::vector<map::KeyframeMessage>* out) {
  map::KeyframeMessage& message = pending.message;
  const map::KeyframeId kf_id = message.keyframe.id;
  const geometry::SE3 T_kf_world = message.keyframe.T_kf_world;
  WorkerOutput output;
  try {
    output = pending.triangulated.get();
  } catch (const std::exception& e) {
    // The keyframe is in the map already: it is finished without these points, not lost.
    keyframe_problem_ =
        "keyframe " + std::to_string(kf_id) + ": no points by keyframe matching (" + e.what() + ")";
  }
  worker_cpu_ms_ += output.cpu_ms;
  for (const TriangulatedPoint& point : output.points) {
    features::PointAppearance appearance;
    if (!appearance.cut(pending.image, point.px)) continue;
    const map::PointId id = addNewPoint(point.p_world, kf_id, std::move(appearance), &message);
    message.keyframe.observations.push_back({id, point.xy});
    message.earlier_observations.push_back({point.other, id, point.other_xy});
    map_.linkPoint(kf_id, id);
    map_.linkPoint(point.other, id);
    pending.occupied.push_back(point.px);
  }
  candidates_.spawn(kf_id, T_kf_world, pending.image, pending.occupied, last_scene_depth_,
                    *frame_camera_);
  // Everything the keyframe matched, refused matches included: the ratio rule then compares the
  // frame's inliers with it (on real images, where 30-46 % of the matches are refused, keyframes
  // come sooner; doc/frontend.md, "Refused matches in the keyframe").
  tracked_at_keyframe_ = static_cast<int>(message.keyframe.observations.size());
  rememberKeyframePoints(message, pending.image);
  // Idle points' patches compressed, looked at every half period (the points due only).
  const auto idle = static_cast<std::uint64_t>(params_.compress_idle_patches_after_frames);
  if (idle > 0 && frame_index_ >= last_patch_sweep_frame_ + idle / 2) {
    map_.compressIdlePatches(frame_index_, idle);
    last_patch_sweep_frame_ = frame_index_;
  }
  out->push_back(std::move(message));
}

void Tracker::finishPendingKeyframe() {
  if (!pending_keyframe_) return;
  PendingKeyframe pending = std::move(*pending_keyframe_);
  pending_keyframe_.reset();
  completeKeyframe(std::move(pending), &finished_keyframes_);
}

bool Tracker::keyframeReady() const {
  return pending_keyframe_ && pending_keyframe_->triangulated.wait_for(std::chrono::seconds(0)) ==
                                  std::future_status::ready;
}

std::vector<map::KeyframeMessage> Tracker::finishKeyframes() {
  finishPendingKeyframe();
  return std::exchange(finished_keyframes_, {});
}

}  // namespace scale_drift_slam::tracking
