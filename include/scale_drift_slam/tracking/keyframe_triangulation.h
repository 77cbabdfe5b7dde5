#pragma once
// New map points by matching between keyframes (doc/frontend.md, "How map points are born"):
// at each keyframe the corners not taken by a map point or a feature candidate are described
// (ORB, upright) and matched against the free corners of the previous keyframes along the
// epipolar lines of the keyframes' poses; each match with enough parallax is triangulated and
// kept when it lies in front of both keyframes and reprojects within a few pixels in both. The
// candidates' inverse-depth filters need the flow to follow a feature over several frames; when
// the view changes fast (a hand-held camera at 1 Hz, a car on a highway) the flow loses most of
// them before their depth is certain and the map starves. Keyframe-time work only: nothing here
// runs per frame. Owned by the tracker; single-threaded.

#include <deque>
#include <functional>
#include <optional>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include "scale_drift_slam/features/feature_detection.h"
#include "scale_drift_slam/features/image_preparation.h"
#include "scale_drift_slam/geometry/camera_model.h"
#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/map/map.h"

namespace scale_drift_slam::tracking {

struct KeyframeTriangulationParams {
  int max_features = 400;            ///< Free corners described per keyframe (0: off).
  int neighbours = 2;                ///< Earlier keyframes matched against (the newest ones).
  int max_descriptor_distance = 50;  ///< ORB Hamming distance of a match (of 256 bits).
  double max_ratio = 0.8;            ///< Best / second-best distance along the epipolar band.
  double max_epipolar_px = 3.0;      ///< Distance of a match from the epipolar line.
  double min_parallax_deg = 1.0;     ///< Angle between the two rays at the point.
  double max_reprojection_px = 2.5;  ///< In both keyframes, after triangulation.
  /// Throws std::invalid_argument naming the first bad value.
  void validate() const;
};

/// A point triangulated between the new keyframe and an earlier one.
struct TriangulatedPoint {
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
  Eigen::Vector2d px = Eigen::Vector2d::Zero();  ///< Raw pixel in the new keyframe.
  Eigen::Vector2d xy = Eigen::Vector2d::Zero();  ///< Normalised, in the new keyframe.
  map::KeyframeId other = 0;                     ///< The earlier keyframe.
  Eigen::Vector2d other_xy = Eigen::Vector2d::Zero();
};

/// The distance (pixels at `focal`) of `xy_b` (normalised, camera b) from the epipolar line of
/// `xy_a` (normalised, camera a); T_b_a maps camera a's frame into camera b's.
double epipolarDistancePx(const geometry::SE3& T_b_a, const Eigen::Vector2d& xy_a,
                          const Eigen::Vector2d& xy_b, double focal);

/// The point closest to both rays (midpoint), in the world; nullopt when the rays are parallel.
std::optional<Eigen::Vector3d> triangulateMidpoint(const geometry::SE3& T_a_world,
                                                   const Eigen::Vector2d& xy_a,
                                                   const geometry::SE3& T_b_world,
                                                   const Eigen::Vector2d& xy_b);

/// Upright ORB descriptors (one row each) of `corners` in the base image; corners too close to
/// the border for ORB's patch are dropped from `corners`.
cv::Mat describeCorners(const cv::Mat& grey, std::vector<cv::KeyPoint>* corners);

/// For each row of `query`, the row of `train` at the smallest Hamming distance when that distance
/// is at most `max_distance` and below `max_ratio` times the second smallest; -1 otherwise. Each
/// train row is kept for its closest query only.
std::vector<int> matchDescriptors(const cv::Mat& query, const cv::Mat& train, int max_distance,
                                  double max_ratio);

class KeyframeTriangulation {
 public:
  /// The current pose of a keyframe (corrected by the mapper), nullopt when it is gone.
  using PoseLookup = std::function<std::optional<geometry::SE3>(map::KeyframeId)>;

  KeyframeTriangulation(const KeyframeTriangulationParams& params,
                        const features::FeatureDetectionParams& detection, double focal_length_px);

  /// The earlier keyframes that addKeyframe() matches with (their poses are looked up).
  std::vector<map::KeyframeId> neighbourIds() const;

  /// At a new keyframe: describes its corners away from `occupied` (pixels of its map points and
  /// of the feature candidates), matches them with the free corners of the `neighbours` newest
  /// earlier keyframes and returns the points triangulated (each corner used once). The new
  /// keyframe's unmatched corners are kept for the next keyframes.
  std::vector<TriangulatedPoint> addKeyframe(map::KeyframeId id, const geometry::SE3& T_kf_world,
                                             const features::ImagePyramid& image,
                                             const std::vector<Eigen::Vector2d>& occupied,
                                             const geometry::CameraModel& camera,
                                             const PoseLookup& pose_of);

 private:
  struct Described {  ///< The free corners of one keyframe.
    map::KeyframeId id = 0;
    std::vector<Eigen::Vector2d> px, xy;
    cv::Mat descriptors;  ///< One row (32 bytes) per corner.
    std::vector<bool> used;
    cv::Mat image;  ///< The keyframe's grey image (shared with its pyramid).
    /// The same with its gradient, padded, for the refinement's Lucas-Kanade
    /// (ImagePyramid::baseLevelForLucasKanade); empty: `image` is given bare.
    std::vector<cv::Mat> image_for_flow;
  };

  Described describe(map::KeyframeId id, const features::ImagePyramid& image,
                     const std::vector<Eigen::Vector2d>& occupied,
                     const geometry::CameraModel& camera) const;
  /// Mutual best descriptor matches (current index, other index) near the epipolar lines.
  std::vector<std::pair<int, int>> matchAlongEpipolarLines(const Described& current,
                                                           const Described& other,
                                                           const geometry::SE3& T_other_cur) const;
  /// The other keyframe's pixel of each pair aligned to the current one's patch; nothing when
  /// the alignment fails or moves it by more than 2 px.
  std::vector<std::optional<Eigen::Vector2d>> refine(
      const Described& current, const Described& other,
      const std::vector<std::pair<int, int>>& pairs) const;
  /// Matches the new keyframe's free corners with one earlier keyframe's; appends the points.
  void match(Described& current, const geometry::SE3& T_cur_world, Described& other,
             const geometry::SE3& T_other_world, const geometry::CameraModel& camera,
             std::vector<TriangulatedPoint>* points) const;

  KeyframeTriangulationParams params_;
  features::FeatureDetectionParams detection_;
  double focal_;
  std::deque<Described> recent_;  ///< The newest keyframes' free corners, oldest first.
};

}  // namespace scale_drift_slam::tracking
