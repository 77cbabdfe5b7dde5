// Tracker: tracking one frame and dropping keyframes (the rest is in tracker.cpp).

#include <algorithm>

#include "scale_drift_slam/common/stopwatch.h"
#include "scale_drift_slam/tracking/tracker.h"

namespace scale_drift_slam::tracking {

void Tracker::track(double timestamp, const features::ImagePyramid& image, FrameResult* result) {
  common::Stopwatch stage;
  // 1. Motion prior: flow from the previous frame (its map points and the feature candidates).
  std::vector<cv::Point2f> candidate_px;
  std::vector<unsigned char> candidate_ok;
  const MotionPrior prior = estimatePrior(image, &candidate_px, &candidate_ok);
  result->times.flow = stage.lapMs();
  // 2-3. Active search for the local map points around the prior.
  std::vector<map::PointId> ids;
  const std::vector<features::SearchMatch> matches = searchLocalMap(prior, image, &ids);
  result->times.search = stage.lapMs();
  // 4. Motion-only BA on the matches (pseudo-Huber), starting at the prior.
  std::vector<Measurement> inliers;
  const geometry::SE3 T_cam_world = solvePose(prior, ids, matches, &inliers, result);
  result->times.motion_ba = stage.lapMs();

  previous_image_ = image;
  const bool from_relocalisation = resume_from_relocalisation_;
  resume_from_relocalisation_ = false;
  if (result->num_inliers < params_.min_inliers) {
    // Lost: say so, keep the last pose, add no keyframe. The filters cannot be updated without
    // a pose, but their pixels follow the flow into this image (the next flow starts from it).
    candidates_.follow(candidate_px, candidate_ok, *camera_);
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
  result->has_pose = true;
  result->T_cam_world = T_cam_world;
  // 5. Inverse-depth filters of the new features, with the flow's measurements.
  candidates_.update(candidate_px, candidate_ok, T_cam_world, *camera_);
  result->times.filters = stage.lapMs();
  // 6. The keyframe rule (tracking is good or weak here, not lost).
  const KeyframeDecision decision =
      decideKeyframe(T_cam_world.inverseTranslation(), map_.keyframeCentres(), last_scene_depth_,
                     params_.keyframes, TrackedPoints{result->num_inliers, tracked_at_keyframe_});
  if (decision.drop) dropKeyframe(timestamp, image, inliers, result);
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
                                T_previous_world_, last_scene_depth_, *camera_, candidate_px,
                                candidate_ok);
}

std::vector<features::SearchMatch> Tracker::searchLocalMap(const MotionPrior& prior,
                                                           const features::ImagePyramid& image,
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
  const features::CornerGrid corners = features::detectSearchCorners(image.base(), params_.search);
  return features::activeSearch(search_points, prior.T_cur_world, prior.Sigma, *camera_, image,
                                corners, params_.search);
}

geometry::SE3 Tracker::solvePose(const MotionPrior& prior, const std::vector<map::PointId>& ids,
                                 const std::vector<features::SearchMatch>& matches,
                                 std::vector<Measurement>* inliers, FrameResult* result) {
  features::MotionOnlyInput input;
  input.T_cam_world_guess = prior.T_cur_world;
  input.focal_length_px = focal_;
  std::vector<std::size_t> used;
  for (std::size_t i = 0; i < matches.size(); ++i) {
    TrackedPoint& point = map_.point(ids[i]);
    point.times_searched += matches[i].searched;
    result->num_visible += matches[i].visible;
    if (!matches[i].found) continue;
    ++point.times_found;
    input.observations.push_back({point.p_world, matches[i].xy});
    used.push_back(i);
  }
  result->num_found = static_cast<int>(used.size());
  if (result->num_found < params_.min_inliers) return prior.T_cur_world;
  const features::MotionOnlyResult solved =
      features::solveMotionOnlyBundleAdjustment(input, params_.motion_ba);
  for (std::size_t k = 0; k < used.size(); ++k) {
    const features::SearchMatch& match = matches[used[k]];
    if (solved.inlier[k]) inliers->push_back({ids[used[k]], match.px, match.xy});
  }
  result->num_inliers = static_cast<int>(inliers->size());
  return solved.T_cam_world;
}

void Tracker::dropKeyframe(double timestamp, const features::ImagePyramid& image,
                           const std::vector<Measurement>& inliers, FrameResult* result) {
  const geometry::SE3& T_kf_world = T_previous_world_;
  map::KeyframeMessage message = makeKeyframe(timestamp, T_kf_world, image);
  const map::KeyframeId kf_id = message.keyframe.id;
  TrackedKeyframe tracked{kf_id, timestamp, T_kf_world, {}};
  std::vector<Eigen::Vector2d> occupied;
  for (const Measurement& m : inliers) {
    message.keyframe.observations.push_back({m.id, m.xy});
    tracked.points.push_back(m.id);
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
    if (const auto px = camera_->project(T_kf_world * feature.p_world)) occupied.push_back(*px);
  }
  candidates_.spawn(kf_id, T_kf_world, image, occupied, last_scene_depth_, *camera_);
  tracked_at_keyframe_ = static_cast<int>(message.keyframe.observations.size());
  result->keyframes.push_back(std::move(message));
}

}  // namespace scale_drift_slam::tracking
