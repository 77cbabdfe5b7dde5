// Tracker: a frame the flow could not carry, tracked again from the newest keyframe's map points
// matched by descriptor (the rest is in tracker.cpp and tracker_frame.cpp).

#include <cmath>

#include "scale_drift_slam/tracking/keyframe_triangulation.h"
#include "scale_drift_slam/tracking/tracker.h"

namespace scale_drift_slam::tracking {
namespace {
constexpr int kRecoveryCorners = 1000;  ///< Corners of the frame described for the recovery.
}  // namespace

void Tracker::rememberKeyframePoints(const map::KeyframeMessage& message,
                                     const features::ImagePyramid& image) {
  keyframe_points_ = {};
  keyframe_points_.frame_index = frame_index_;
  if (!params_.recover_from_keyframe) return;
  keyframe_points_.image = image.base();  // shared, not copied
  for (const map::Observation& o : message.keyframe.observations) {
    const std::optional<Eigen::Vector2d> px =
        frame_camera_->project(o.xyd().homogeneous());  // measured
    if (!px) continue;
    cv::KeyPoint corner(static_cast<float>(px->x()), static_cast<float>(px->y()), 31.0f);
    corner.class_id = static_cast<int>(keyframe_points_.ids.size());
    keyframe_points_.corners.push_back(corner);
    keyframe_points_.ids.push_back(o.point_id);
  }
}

void Tracker::describeKeyframePoints() {
  if (keyframe_points_.described) return;
  keyframe_points_.described = true;
  describePoints(&keyframe_points_);
}

void Tracker::describePoints(DescribedPoints* points) {
  std::vector<cv::KeyPoint> corners = std::move(points->corners);
  points->descriptors = describeCorners(points->image, &corners);
  std::vector<map::PointId> ids;
  for (const cv::KeyPoint& corner : corners)
    ids.push_back(points->ids[corner.class_id]);
  points->ids = std::move(ids);
  points->image.release();
}

Tracker::DescribedPoints Tracker::previousFramePoints() const {
  DescribedPoints points;
  points.image = previous_image_.base();
  for (const Measurement& m : previous_measurements_) {
    cv::KeyPoint corner(static_cast<float>(m.px.x()), static_cast<float>(m.px.y()), 31.0f);
    corner.class_id = static_cast<int>(points.ids.size());
    points.corners.push_back(corner);
    points.ids.push_back(m.id);
  }
  describePoints(&points);
  return points;
}

std::optional<geometry::SE3> Tracker::poseFromDescribedPoints(const DescribedPoints& points,
                                                              const FrameCorners& frame) {
  const int min_matches = params_.min_inliers;
  if (static_cast<int>(points.ids.size()) < min_matches) return std::nullopt;
  const std::vector<int> match =
      matchDescriptors(points.descriptors, frame.descriptors,
                       params_.recovery_max_descriptor_distance, params_.recovery_max_ratio);
  features::MotionOnlyInput input;
  input.focal_length_px = focal_;
  for (std::size_t i = 0; i < match.size(); ++i) {
    if (match[i] < 0 || !map_.hasPoint(points.ids[i])) continue;
    const cv::Point2f& px = frame.keypoints[match[i]].pt;
    input.observations.push_back(
        {map_.point(points.ids[i]).p_world,
         frame_camera_->undistortToNormalized(Eigen::Vector2d(px.x, px.y))});
  }
  if (static_cast<int>(input.observations.size()) < min_matches) return std::nullopt;
  // EPnP in RANSAC, refined on its inliers with the tracker's own robust motion-only BA.
  std::vector<int> kept;
  const std::optional<features::MotionOnlyResult> solved = features::solvePoseWithoutGuess(
      input, {params_.motion_ba.inlier_threshold_px, 200, 0.99, features::PnpSampleSolver::kEPnP},
      params_.motion_ba, &kept);
  if (!solved || static_cast<int>(kept.size()) < min_matches) return std::nullopt;
  return solved->T_cam_world;
}

void Tracker::recoverFromKeyframe(const features::ImagePyramid& image,
                                  const features::CornerGrid& corners,
                                  const std::vector<map::PointId>& ids,
                                  const std::vector<features::SearchPoint>& search_points,
                                  std::vector<features::SearchMatch>* matches,
                                  std::vector<Measurement>* inliers, geometry::SE3* T_solved,
                                  FrameResult* result) {
  // The newest keyframe's points; then the previous frame's inliers, a newer view of the map
  // when it is not that keyframe (at a low frame rate the view changes a lot per frame).
  describeKeyframePoints();
  const auto enough = [this](std::size_t n) { return static_cast<int>(n) >= params_.min_inliers; };
  const bool from_previous = enough(previous_measurements_.size()) &&
                             !previous_image_.levels.empty() &&
                             keyframe_points_.frame_index + 1 != frame_index_;
  if (!enough(keyframe_points_.ids.size()) && !from_previous) return;
  FrameCorners frame;
  // Described at full resolution: the search corners may be half-resolution seeds.
  frame.keypoints = features::distributeQuadtree(
      image.corners()->detect(params_.search.fast_threshold, params_.search.template_radius + 1),
      kRecoveryCorners, frame_camera_->width(), frame_camera_->height());
  frame.descriptors = describeCorners(image.base(), &frame.keypoints);
  const bool recovered =
      tryPoseFrom(poseFromDescribedPoints(keyframe_points_, frame), image, corners, ids,
                  search_points, matches, inliers, T_solved, result);
  if (!recovered && from_previous) {
    tryPoseFrom(poseFromDescribedPoints(previousFramePoints(), frame), image, corners, ids,
                search_points, matches, inliers, T_solved, result);
  }
}

bool Tracker::tryPoseFrom(const std::optional<geometry::SE3>& T_pnp,
                          const features::ImagePyramid& image, const features::CornerGrid& corners,
                          const std::vector<map::PointId>& ids,
                          const std::vector<features::SearchPoint>& search_points,
                          std::vector<features::SearchMatch>* matches,
                          std::vector<Measurement>* inliers, geometry::SE3* T_solved,
                          FrameResult* result) {
  if (!T_pnp) return false;
  // Around the PnP pose: a few times the prior's floor (the pose rests on a few dozen matches).
  const double depth = last_scene_depth_ > 0.0 ? last_scene_depth_ : 1.0;
  const double k = 3.0;
  Eigen::Matrix<double, 6, 1> d;
  d << Eigen::Vector3d::Constant(std::pow(k * params_.motion_prior.min_rotation_sigma, 2)),
      Eigen::Vector3d::Constant(
          std::pow(k * params_.motion_prior.min_translation_sigma * depth, 2));
  std::vector<features::SearchMatch> found = features::activeSearch(
      search_points, *T_pnp, d.asDiagonal(), *frame_camera_, image, corners, params_.search);
  std::vector<Measurement> more_inliers;
  FrameResult counts;
  const geometry::SE3 T = solvePose(*T_pnp, ids, found, &more_inliers, &counts);
  if (counts.num_inliers <= result->num_inliers) return false;
  *matches = std::move(found);
  *T_solved = T;
  *inliers = std::move(more_inliers);
  result->num_found = counts.num_found;
  result->num_inliers = counts.num_inliers;
  result->pose_information = counts.pose_information;
  return true;
}

}  // namespace scale_drift_slam::tracking
