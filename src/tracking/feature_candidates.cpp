#include "scale_drift_slam/tracking/feature_candidates.h"

#include <stdexcept>
#include <unordered_map>

#include "scale_drift_slam/map/map_update.h"

namespace scale_drift_slam::tracking {

void FeatureCandidateParams::validate() const {
  filter.validate();
  if (max_candidates < 0) throw std::invalid_argument("candidates.max_candidates must be >= 0");
  if (new_per_keyframe < 0) throw std::invalid_argument("candidates.new_per_keyframe must be >= 0");
  if (max_rejections < 1) throw std::invalid_argument("candidates.max_rejections must be >= 1");
  if (max_views < 2) throw std::invalid_argument("candidates.max_views must be >= 2");
}

FeatureCandidates::FeatureCandidates(const FeatureCandidateParams& params,
                                     const features::FeatureDetectionParams& detection,
                                     double focal_length_px)
    : params_(params), detection_(detection), focal_length_px_(focal_length_px) {
  params_.validate();
  detection_.validate();
}

std::vector<cv::Point2f> FeatureCandidates::pixels() const {
  std::vector<cv::Point2f> px;
  px.reserve(candidates_.size());
  for (const Candidate& c : candidates_) {
    px.emplace_back(static_cast<float>(c.px.x()), static_cast<float>(c.px.y()));
  }
  return px;
}

int FeatureCandidates::numCertain() const {
  int n = 0;
  for (const Candidate& c : candidates_)
    n += c.filter.isCertain();
  return n;
}

int FeatureCandidates::update(const std::vector<cv::Point2f>& tracked,
                              const std::vector<unsigned char>& ok,
                              const geometry::SE3& T_cur_world,
                              const geometry::CameraModel& camera) {
  return move(tracked, ok, &T_cur_world, camera);
}

void FeatureCandidates::follow(const std::vector<cv::Point2f>& tracked,
                               const std::vector<unsigned char>& ok,
                               const geometry::CameraModel& camera) {
  move(tracked, ok, nullptr, camera);
}

int FeatureCandidates::move(const std::vector<cv::Point2f>& tracked,
                            const std::vector<unsigned char>& ok, const geometry::SE3* T_cur_world,
                            const geometry::CameraModel& camera) {
  int updated = 0;
  std::size_t kept = 0;
  for (std::size_t i = 0; i < candidates_.size(); ++i) {
    Candidate& c = candidates_[i];
    if (i >= ok.size() || !ok[i]) continue;
    c.px = Eigen::Vector2d(tracked[i].x, tracked[i].y);
    c.xy = camera.undistortToNormalized(c.px);
    if (T_cur_world) {
      const InverseDepthFilter::Update result = c.filter.update(*T_cur_world, c.xy);
      if (result == InverseDepthFilter::Update::kUpdated) ++updated;
      if (result == InverseDepthFilter::Update::kRejected &&
          ++c.rejections >= params_.max_rejections) {
        continue;
      }
    }
    if (kept != i) candidates_[kept] = std::move(c);
    ++kept;
  }
  candidates_.erase(candidates_.begin() + kept, candidates_.end());
  return updated;
}

std::vector<PromotedFeature> FeatureCandidates::promote(map::KeyframeId keyframe,
                                                        const geometry::SE3& T_kf_world) {
  std::vector<PromotedFeature> promoted;
  std::size_t kept = 0;
  for (std::size_t i = 0; i < candidates_.size(); ++i) {
    Candidate& c = candidates_[i];
    c.views.push_back({keyframe, T_kf_world, c.xy});
    if (static_cast<int>(c.views.size()) > params_.max_views) {
      c.views.erase(c.views.begin() + 1);  // keep the origin and the newest views
    }
    if (c.filter.isCertain()) {
      const PromotionResult result = promoteFeature(c.filter, c.views, focal_length_px_);
      if (result.accepted) {
        promoted.push_back({result.p_world, c.filter.originId(), c.views, c.appearance});
        continue;
      }
      if (result.inconsistent || ++c.rejections >= params_.max_rejections) continue;
    }
    if (kept != i) candidates_[kept] = std::move(c);
    ++kept;
  }
  candidates_.erase(candidates_.begin() + kept, candidates_.end());
  return promoted;
}

int FeatureCandidates::spawn(map::KeyframeId keyframe, const geometry::SE3& T_kf_world,
                             const features::ImagePyramid& image,
                             std::vector<Eigen::Vector2d> occupied, double scene_depth,
                             const geometry::CameraModel& camera) {
  const int room = std::min(params_.new_per_keyframe,
                            params_.max_candidates - static_cast<int>(candidates_.size()));
  if (room <= 0 || !(scene_depth > 0.0)) return 0;
  for (const Candidate& c : candidates_)
    occupied.push_back(c.px);
  int added = 0;
  for (const cv::KeyPoint& corner :
       features::detectSpreadCorners(image, room, detection_, occupied)) {
    const Eigen::Vector2d px(corner.pt.x, corner.pt.y);
    features::PointAppearance appearance;
    if (!appearance.cut(image, px)) continue;
    const Eigen::Vector2d xy = camera.undistortToNormalized(px);
    Candidate c{InverseDepthFilter(keyframe, T_kf_world, xy, 1.0 / scene_depth, focal_length_px_,
                                   params_.filter),
                std::move(appearance),
                px,
                xy,
                {{keyframe, T_kf_world, xy}},
                0};
    candidates_.push_back(std::move(c));
    ++added;
  }
  return added;
}

void FeatureCandidates::apply(const map::MapUpdate& update) {
  if (update.keyframe_poses.empty() && !update.S_new_old) return;
  std::unordered_map<map::KeyframeId, const geometry::SE3*> poses;
  for (const auto& [id, T_kf_world] : update.keyframe_poses)
    poses[id] = &T_kf_world;
  std::unordered_map<map::KeyframeId, double> scales;  // of the loop correction per keyframe
  for (const auto& [id, C] : update.keyframe_corrections)
    scales[id] = C.scale();
  for (Candidate& c : candidates_) {
    for (PromotionView& view : c.views) {
      if (update.S_new_old) view.T_kf_world = map::correctPose(view.T_kf_world, *update.S_new_old);
      const auto pose = poses.find(view.keyframe_id);
      if (pose != poses.end()) view.T_kf_world = *pose->second;
    }
    c.filter.setOriginPose(c.views.front().T_kf_world);
    if (update.S_new_old) {
      // The world near the origin keyframe was scaled by s: so is the feature's depth.
      const auto scale = scales.find(c.filter.originId());
      c.filter.rescaleDepth(scale != scales.end() ? scale->second : update.S_new_old->scale());
    }
  }
}

void FeatureCandidates::moveTail(map::KeyframeId anchor, const geometry::SE3& C_new_old) {
  const geometry::SE3 C_old_new = C_new_old.inverse();
  for (Candidate& c : candidates_) {
    for (PromotionView& view : c.views) {
      if (view.keyframe_id > anchor) view.T_kf_world = view.T_kf_world * C_old_new;
    }
    c.filter.setOriginPose(c.views.front().T_kf_world);
  }
}

}  // namespace scale_drift_slam::tracking
