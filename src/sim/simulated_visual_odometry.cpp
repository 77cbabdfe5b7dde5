#include "scale_drift_slam/sim/simulated_visual_odometry.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "scale_drift_slam/common/stopwatch.h"

namespace scale_drift_slam::sim {
void SimulatedVoParams::validate() const {
  window.validate();
  motion.validate();
  filter.validate();
  keyframe_rule.validate();
  auto fail = [](const std::string& what) {
    throw std::invalid_argument("simulated visual odometry: " + what);
  };
  if (local_map_keyframes < 1) fail("local_map_keyframes must be >= 1");
  if (max_features_per_keyframe < 1) fail("max_features_per_keyframe must be >= 1");
  if (grid_columns < 1 || grid_rows < 1) fail("the grid needs >= 1 column and row");
  if (promotion_keyframes < 2) fail("promotion_keyframes must be >= 2");
  if (max_filter_age_keyframes < 1) fail("max_filter_age_keyframes must be >= 1");
  if (bootstrap_keyframes < window.num_fixed_keyframes) {
    fail("bootstrap_keyframes must be >= the window's fixed keyframes");
  }
  if (min_tracked_points < 3) fail("min_tracked_points must be >= 3");
  if (!(initial_scene_depth > 0.0)) fail("initial_scene_depth must be > 0");
}

SimulatedVoParams voParamsForNoise(SimulatedVoParams params, double noise_px) {
  if (!(noise_px >= 0.0) || !std::isfinite(noise_px)) {
    throw std::invalid_argument("simulated visual odometry: the noise must be >= 0 pixels");
  }
  params.filter.pixel_sigma_px = std::max(noise_px, 0.5);
  const double factor = std::max(noise_px, 1.0);
  params.filter.max_promotion_error_px *= factor;
  params.motion.huber_width_px *= factor;
  params.motion.inlier_threshold_px *= factor;
  params.window.huber_width_px *= factor;
  params.window.inlier_threshold_px *= factor;
  return params;
}

SimulatedVisualOdometry::SimulatedVisualOdometry(const PinholeCamera& camera,
                                                 const SimulatedVoParams& params)
    : camera_(camera), params_(params) {
  params_.validate();
  if (!(camera_.focal_length > 0.0)) throw std::invalid_argument("camera focal length must be > 0");
}

bool SimulatedVisualOdometry::bootstrapping() const {
  return static_cast<int>(keyframes_.size()) < params_.bootstrap_keyframes ||
         static_cast<int>(map_.numPoints()) < params_.min_bootstrap_points;
}

bool SimulatedVisualOdometry::isActive(map::PointId id) const {
  const auto it = last_seen_.find(id);
  return it != last_seen_.end() && it->second + params_.local_map_keyframes >= keyframes_.size();
}

geometry::SE3 SimulatedVisualOdometry::predictPose() const {
  const std::size_t n = frame_poses_.size();
  if (n < 2) return frame_poses_.back();
  // Constant velocity: Delta = T_{i-1} T_{i-2}^-1, T_i = Delta T_{i-1}.
  return frame_poses_[n - 1] * frame_poses_[n - 2].inverse() * frame_poses_[n - 1];
}

std::vector<SimulatedVisualOdometry::Tracked> SimulatedVisualOdometry::track(
    const std::vector<Measurement>& measurements, geometry::SE3* pose) {
  std::vector<Tracked> tracked;
  features::MotionOnlyInput input;
  input.T_cam_world_guess = *pose;
  input.focal_length_px = camera_.focal_length;
  for (const Measurement& m : measurements) {
    const auto it = sim_to_point_.find(m.point);
    if (it == sim_to_point_.end() || !isActive(it->second)) continue;
    tracked.push_back({it->second, m.xy});
    input.observations.push_back({map_.point(it->second).p_world, m.xy});
  }
  if (static_cast<int>(tracked.size()) < params_.min_tracked_points) {
    ++stats_.lost_frames;
    return tracked;
  }
  const common::Stopwatch timer;
  const features::MotionOnlyResult result =
      features::solveMotionOnlyBundleAdjustment(input, params_.motion);
  stats_.motion_ba_ms += timer.ms();
  *pose = result.T_cam_world;
  std::vector<Tracked> inliers;
  for (std::size_t i = 0; i < tracked.size(); ++i) {
    if (result.inlier[i]) inliers.push_back(tracked[i]);
  }
  return inliers;
}

void SimulatedVisualOdometry::updateFilters(const std::vector<Measurement>& measurements,
                                            const geometry::SE3& pose) {
  for (const Measurement& m : measurements) {
    const auto it = filters_.find(m.point);
    if (it != filters_.end()) it->second.update(pose, m.xy);
  }
}

double SimulatedVisualOdometry::sceneDepth(const geometry::SE3& pose,
                                           const std::vector<Tracked>& tracked) const {
  std::vector<Eigen::Vector3d> points;
  for (const Tracked& t : tracked)
    points.push_back(map_.point(t.point).p_world);
  if (points.size() < 3) return params_.initial_scene_depth;
  return tracking::medianSceneDepth(pose, points);
}

bool SimulatedVisualOdometry::keyframeDue(const geometry::SE3& pose, double depth) const {
  if (keyframes_.empty()) return true;
  std::vector<std::pair<map::KeyframeId, Eigen::Vector3d>> centres;
  const std::size_t first =
      keyframes_.size() > static_cast<std::size_t>(params_.local_map_keyframes)
          ? keyframes_.size() - params_.local_map_keyframes
          : 0;
  for (std::size_t k = first; k < keyframes_.size(); ++k) {
    const map::KeyframeId id = keyframes_[k].id;
    centres.emplace_back(id, map_.keyframe(id).T_kf_world.inverseTranslation());
  }
  return tracking::decideKeyframe(pose.inverseTranslation(), centres, depth, params_.keyframe_rule)
      .drop;
}

void SimulatedVisualOdometry::processFrame(std::size_t frame,
                                           const std::vector<Measurement>& measurements,
                                           const geometry::SE3& T_true_cam_world) {
  if (frame != frame_poses_.size()) {
    throw std::invalid_argument("simulated visual odometry: frames must come in order from 0");
  }
  ++stats_.frames;
  const bool bootstrap = bootstrapping();
  geometry::SE3 pose = bootstrap ? T_true_cam_world : predictPose();
  std::vector<Tracked> tracked = track(measurements, &pose);
  if (bootstrap) {
    pose = T_true_cam_world;
    if (static_cast<int>(tracked.size()) < params_.min_tracked_points) --stats_.lost_frames;
  }
  frame_poses_.push_back(pose);
  updateFilters(measurements, pose);
  const double depth = sceneDepth(pose, tracked);
  if (keyframeDue(pose, depth)) {
    addKeyframe(frame, measurements, tracked, pose, depth);
    frame_records_.push_back({keyframes_.size() - 1, geometry::SE3()});
  } else {
    const geometry::SE3& T_kf_world = map_.keyframe(keyframes_.back().id).T_kf_world;
    frame_records_.push_back({keyframes_.size() - 1, pose * T_kf_world.inverse()});
  }
}

std::vector<geometry::SE3> SimulatedVisualOdometry::framePosesThroughKeyframes() const {
  std::vector<geometry::SE3> poses;
  poses.reserve(frame_records_.size());
  for (const FrameRecord& record : frame_records_) {
    poses.push_back(record.T_frame_kf * map_.keyframe(keyframes_[record.keyframe].id).T_kf_world);
  }
  return poses;
}

void SimulatedVisualOdometry::addKeyframe(std::size_t frame,
                                          const std::vector<Measurement>& measurements,
                                          const std::vector<Tracked>& tracked,
                                          const geometry::SE3& pose, double depth) {
  const bool bootstrap = bootstrapping();
  map::Keyframe kf;
  kf.id = static_cast<map::KeyframeId>(keyframes_.size());
  kf.timestamp = static_cast<double>(frame);
  kf.T_kf_world = pose;
  for (const Tracked& t : tracked)
    kf.observations.push_back({t.point, t.xy});
  map_.addKeyframe(kf);
  KeyframeRecord record;
  record.id = kf.id;
  record.frame = frame;
  for (const Measurement& m : measurements)
    record.measurements.emplace(m.point, m.xy);
  keyframe_index_[kf.id] = keyframes_.size();
  keyframes_.push_back(std::move(record));
  for (const Tracked& t : tracked)
    last_seen_[t.point] = keyframes_.size() - 1;

  promoteFilters();
  startFilters(measurements, tracked, depth);
  if (!bootstrap) runWindowBundleAdjustment();
}

void SimulatedVisualOdometry::promoteFilters() {
  const std::size_t newest = keyframes_.size() - 1;
  for (auto it = filters_.begin(); it != filters_.end();) {
    const tracking::InverseDepthFilter& filter = it->second;
    const std::size_t origin = keyframe_index_.at(filter.originId());
    if (!filter.isCertain()) {
      const bool stale = origin + params_.max_filter_age_keyframes < newest;
      it = stale ? filters_.erase(it) : std::next(it);
      continue;
    }
    // The keyframes from the origin to the newest that measured the feature; take the origin,
    // the newest and evenly spaced ones between (paper: "about three surrounding keyframes").
    std::vector<std::size_t> seen;
    for (std::size_t k = origin; k <= newest; ++k) {
      if (keyframes_[k].measurements.count(it->first)) seen.push_back(k);
    }
    std::vector<tracking::PromotionView> views;
    const std::size_t n = std::min<std::size_t>(params_.promotion_keyframes, seen.size());
    for (std::size_t v = 0; v < n; ++v) {
      const std::size_t k = n == 1 ? seen.back() : seen[v * (seen.size() - 1) / (n - 1)];
      views.push_back({keyframes_[k].id, map_.keyframe(keyframes_[k].id).T_kf_world,
                       keyframes_[k].measurements.at(it->first)});
    }
    const tracking::PromotionResult result =
        tracking::promoteFeature(filter, views, camera_.focal_length);
    if (result.accepted) {
      map::MapPoint point;
      point.id = next_point_id_++;
      point.p_world = result.p_world;
      point.reference_keyframe = views.back().keyframe_id;
      map_.addPoint(point);
      for (const tracking::PromotionView& view : views)
        map_.addObservation(view.keyframe_id, point.id, view.xy);
      sim_to_point_[it->first] = point.id;
      point_to_sim_[point.id] = it->first;
      last_seen_[point.id] = newest;
      ++stats_.promoted;
    } else {
      ++stats_.promotions_rejected;
    }
    it = filters_.erase(it);
  }
}

void SimulatedVisualOdometry::startFilters(const std::vector<Measurement>& measurements,
                                           const std::vector<Tracked>& tracked, double depth) {
  // Occupancy of a grid over the image by tracked points and running filters; new filters go to
  // cells below their share (the paper spreads features with a quadtree).
  const int cells = params_.grid_columns * params_.grid_rows;
  const int per_cell = (params_.max_features_per_keyframe + cells - 1) / cells;
  std::vector<int> occupancy(cells, 0);
  auto cell_of = [&](const Eigen::Vector2d& xy) {
    const Eigen::Vector2d pixel = camera_.focal_length * xy + camera_.principal_point;
    const int cx = std::clamp(static_cast<int>(pixel.x() * params_.grid_columns / camera_.width), 0,
                              params_.grid_columns - 1);
    const int cy = std::clamp(static_cast<int>(pixel.y() * params_.grid_rows / camera_.height), 0,
                              params_.grid_rows - 1);
    return cy * params_.grid_columns + cx;
  };
  for (const Tracked& t : tracked)
    ++occupancy[cell_of(t.xy)];
  for (const Measurement& m : measurements) {
    if (filters_.count(m.point)) ++occupancy[cell_of(m.xy)];
  }
  const map::KeyframeId id = keyframes_.back().id;
  const geometry::SE3& T = map_.keyframe(id).T_kf_world;
  for (const Measurement& m : measurements) {
    const auto point = sim_to_point_.find(m.point);
    if (point != sim_to_point_.end() && isActive(point->second)) continue;
    if (filters_.count(m.point)) continue;
    int& count = occupancy[cell_of(m.xy)];
    if (count >= per_cell) continue;
    ++count;
    filters_.emplace(m.point, tracking::InverseDepthFilter(id, T, m.xy, 1.0 / depth,
                                                           camera_.focal_length, params_.filter));
    ++stats_.filters_started;
  }
}

void SimulatedVisualOdometry::runWindowBundleAdjustment() {
  if (map_.numKeyframes() <= static_cast<std::size_t>(params_.window.num_fixed_keyframes)) return;
  const common::Stopwatch timer;
  const mapping::WindowBundleInput input =
      mapping::makeWindowInput(map_, params_.window, camera_.focal_length);
  const mapping::WindowBundleResult result =
      mapping::solveWindowBundleAdjustment(input, params_.window);
  mapping::applyWindowResult(result, map_);
  stats_.window_ba_ms += timer.ms();
  ++stats_.window_ba_runs;
  // Filters stay attached to their (re-optimised) origin keyframes; the newest frame is the
  // newest keyframe.
  for (auto& [sim_id, filter] : filters_)
    filter.setOriginPose(map_.keyframe(filter.originId()).T_kf_world);
  frame_poses_.back() = map_.keyframe(keyframes_.back().id).T_kf_world;
}

}  // namespace scale_drift_slam::sim
