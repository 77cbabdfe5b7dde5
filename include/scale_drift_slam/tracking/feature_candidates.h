#pragma once
// New features between their birth at a keyframe and their promotion to map points
// (doc/algorithm.md, "Front-end: feature initialisation with inverse-depth information
// filters"): FAST corners spread by the quadtree at each keyframe, each with its own
// InverseDepthFilter (tracking/inverse_depth_filter.h), followed frame to frame by the motion
// prior's optical flow and updated on frames with enough parallax; at each later keyframe the
// certain ones go through the promotion rule (promoteFeature) and become map points. A filtered
// feature never enters pose estimation. Owned by the tracker; single-threaded.

#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "scale_drift_slam/features/active_search.h"
#include "scale_drift_slam/features/feature_detection.h"
#include "scale_drift_slam/features/image_preparation.h"
#include "scale_drift_slam/geometry/camera_model.h"
#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/map/keyframe_message.h"
#include "scale_drift_slam/tracking/inverse_depth_filter.h"

namespace scale_drift_slam::tracking {

struct FeatureCandidateParams {
  InverseDepthFilterParams filter;
  int max_candidates = 300;    ///< Candidates alive at once.
  int new_per_keyframe = 150;  ///< New candidates started at a keyframe (at most).
  int max_rejections = 2;      ///< Drop a candidate after this many rejected updates or promotions.
  int max_views = 4;           ///< Keyframe views kept for the promotion BA.
  void validate() const;
};

/// A candidate that passed the promotion rule.
struct PromotedFeature {
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
  map::KeyframeId origin = 0;
  std::vector<PromotionView> views;      ///< Origin first; the newest keyframe last.
  features::PointAppearance appearance;  ///< Cut from the origin keyframe.
};

class FeatureCandidates {
 public:
  FeatureCandidates(const FeatureCandidateParams& params,
                    const features::FeatureDetectionParams& detection, double focal_length_px);

  /// Current pixels of the candidates, to be moved by the frame's optical flow.
  std::vector<cv::Point2f> pixels() const;
  /// Takes the flow result (same order as pixels()) and updates the filters with the frame pose.
  /// Candidates lost by the flow or rejected too often are dropped. Returns the number updated.
  int update(const std::vector<cv::Point2f>& tracked, const std::vector<unsigned char>& ok,
             const geometry::SE3& T_cur_world, const geometry::CameraModel& camera);
  /// The same on a frame without a pose (tracking lost): the candidates only follow the flow, so
  /// that their pixels stay in the latest image; those lost by the flow are dropped.
  void follow(const std::vector<cv::Point2f>& tracked, const std::vector<unsigned char>& ok,
              const geometry::CameraModel& camera);

  /// At a new keyframe: records the view of every candidate, promotes the certain ones that
  /// pass the promotion rule (removing them), and returns those.
  std::vector<PromotedFeature> promote(map::KeyframeId keyframe, const geometry::SE3& T_kf_world);

  /// Starts new candidates at the keyframe, away from `occupied` pixels (tracked points and the
  /// other candidates). `scene_depth` gives the filters' start value (its information is zero).
  int spawn(map::KeyframeId keyframe, const geometry::SE3& T_kf_world,
            const features::ImagePyramid& image, std::vector<Eigen::Vector2d> occupied,
            double scene_depth, const geometry::CameraModel& camera);

  /// Keeps origin and view poses in step with the mapper's corrections.
  void apply(const map::MapUpdate& update);
  /// The views at keyframes newer than `anchor` move with it by the world correction
  /// `C_new_old` (TrackingMap::tailCorrection).
  void moveTail(map::KeyframeId anchor, const geometry::SE3& C_new_old);

  std::size_t size() const { return candidates_.size(); }
  /// Candidates whose depth is certain enough for promotion (at the next keyframe).
  int numCertain() const;

 private:
  struct Candidate {
    InverseDepthFilter filter;
    features::PointAppearance appearance;
    Eigen::Vector2d px = Eigen::Vector2d::Zero();  ///< Pixel in the latest frame.
    Eigen::Vector2d xy = Eigen::Vector2d::Zero();  ///< Its normalised coordinates.
    std::vector<PromotionView> views;              ///< Origin first.
    int rejections = 0;
  };

  /// update() and follow(): moves the candidates to the tracked pixels and, given a pose, updates
  /// their filters.
  int move(const std::vector<cv::Point2f>& tracked, const std::vector<unsigned char>& ok,
           const geometry::SE3* T_cur_world, const geometry::CameraModel& camera);

  FeatureCandidateParams params_;
  features::FeatureDetectionParams detection_;
  double focal_length_px_;
  std::vector<Candidate> candidates_;
};

}  // namespace scale_drift_slam::tracking
