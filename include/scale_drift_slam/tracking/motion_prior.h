#pragma once
// The initial pose guess of a frame (doc/algorithm.md, "Front-end: tracking one frame", step
// 1): optical flow carries the previous frame's matched map points into the current image, and a
// motion-only bundle adjustment on those 2D-3D pairs gives T_i^(0) = Delta T_{i-1} together with
// its uncertainty Sigma_Delta = sigma_flow^2 (J^T J)^-1 (plus a floor), which bounds the active
// search regions. Without enough flow tracks it falls back to a constant-velocity guess with a
// wide uncertainty. Owned by the tracker; single-threaded.

#include <optional>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "scale_drift_slam/features/image_preparation.h"
#include "scale_drift_slam/features/motion_only_bundle_adjustment.h"
#include "scale_drift_slam/geometry/camera_model.h"
#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/tracking/optical_flow.h"

namespace scale_drift_slam::tracking {

struct MotionPriorParams {
  OpticalFlowParams flow;
  double flow_sigma_px = 0.5;               ///< Noise of a flow track (pixels).
  int min_tracks = 12;                      ///< Fewer flow tracks: constant-velocity fallback.
  int max_tracks = 150;                     ///< At most this many map points are flowed (evenly).
  double min_rotation_sigma = 0.002;        ///< Floor of Sigma_Delta (radians).
  double min_translation_sigma = 0.005;     ///< Floor of Sigma_Delta (fraction of the scene depth).
  double fallback_rotation_sigma = 0.05;    ///< Sigma_Delta of the fallback (radians).
  double fallback_translation_sigma = 0.1;  ///< ...(fraction of the scene depth).
  /// Start the flow of each map point where the constant-velocity motion moves it, and of each
  /// candidate where the pose measured from the map points' flow moves it at the scene depth,
  /// not where it was: a fast but steady turn moves the image by more than Lucas-Kanade's pyramid
  /// reaches from zero.
  bool predict_flow = true;
  /// Drop the candidates' (new features') tracks whose backward flow misses the start by more
  /// than this (pixels; <= 0: no check unless flow.max_forward_backward_px checks all tracks).
  /// Their tracks feed the inverse-depth filters directly, with no robust cost to reject a track
  /// that slid along its epipolar line, and the points they are promoted to are then wrong.
  double candidate_max_forward_backward_px = 2.0;
  /// Lucas-Kanade window of the candidates' flow, forward and backward (pixels, odd; 0:
  /// flow.window). They are FAST corners, followed a frame at a time from a predicted start and
  /// vetted both ways, and they are most of the points a frame flows: with OpenCV's 8-pixel SIMD
  /// rows a 9-pixel window costs ~35 % less than an 11-pixel one (doc/benchmarks.md, "The
  /// candidates' flow window").
  int candidate_flow_window = 9;
  void validate() const;
};

struct MotionPrior {
  geometry::SE3 T_cur_world;
  Eigen::Matrix<double, 6, 6> Sigma = Eigen::Matrix<double, 6, 6>::Identity();
  bool from_flow = false;
  int num_tracks = 0;  ///< Flow tracks used.
};

/// The previous frame's measurements the flow carries over: pixel and the map point.
struct FlowSeed {
  cv::Point2f px;
  Eigen::Vector3d p_world;
};

class MotionPriorEstimator {
 public:
  MotionPriorEstimator(const MotionPriorParams& params,
                       const features::MotionOnlyBundleAdjustmentParams& motion_ba);

  /// Tracks `seeds` from `previous` into `current` and estimates the prior from them, then
  /// `extra_px` (e.g. the feature candidates, returned through `extra_tracked` / `extra_ok`) with
  /// their own window. `T_guess` is the constant-velocity guess of the current pose, `T_previous`
  /// the previous frame's pose; `scene_depth` scales the floors. When the pose from the flow is
  /// weak (inliers fewer than half the seeds' tracks) and the image's shift is far from the flow's
  /// start (flow.shift_retry_px), the seeds are tracked again from the shift and the set of tracks
  /// whose pose has more inliers is kept. The extra points start where the prior's pose moves
  /// them at `scene_depth` (the guess's pose when the flow gave none).
  MotionPrior estimate(const features::ImagePyramid& previous,
                       const features::ImagePyramid& current, const std::vector<FlowSeed>& seeds,
                       const std::vector<cv::Point2f>& extra_px, const geometry::SE3& T_guess,
                       const geometry::SE3& T_previous, double scene_depth,
                       const geometry::CameraModel& camera, std::vector<cv::Point2f>* extra_tracked,
                       std::vector<unsigned char>* extra_ok);

  /// The fallback: the guess with the wide uncertainty.
  MotionPrior fallback(const geometry::SE3& T_guess, double scene_depth) const;

  /// Points carried through a run of frames, and the pose at the last frame.
  struct Carried {
    geometry::SE3 T_cam_world;
    std::vector<std::size_t> seed;  ///< Index into the seeds of each surviving point...
    std::vector<cv::Point2f> px;    ///< ...and its pixel in the last frame.
  };
  /// Carries `seeds` (pixels in frames[0]) through `frames` by flow from each frame to the next
  /// (a jump over several frames is beyond the flow when the camera moves fast) and estimates the
  /// pose at the last frame by motion-only BA from `T_guess`; only its inliers are returned. For
  /// a relocalisation answered a few frames after the frame it was asked for. Nothing when fewer
  /// than min_tracks points survive.
  std::optional<Carried> carry(const std::vector<features::ImagePyramid>& frames,
                               const std::vector<FlowSeed>& seeds, const geometry::SE3& T_guess,
                               const geometry::CameraModel& camera);

 private:
  /// The pose from the seeds' tracks (`to`, `ok`: the first picked.size() entries), or the
  /// fallback when too few tracks or inliers.
  MotionPrior priorFromTracks(const std::vector<FlowSeed>& picked,
                              const std::vector<cv::Point2f>& to,
                              const std::vector<unsigned char>& ok, const geometry::SE3& T_guess,
                              double scene_depth, const geometry::CameraModel& camera) const;
  /// The image's shift (imageShift) when it is more than flow.shift_retry_px from the median
  /// displacement the flow started from (`start` - `from`); (0, 0) otherwise.
  cv::Point2d shiftAwayFrom(const features::ImagePyramid& previous,
                            const features::ImagePyramid& current,
                            const std::vector<cv::Point2f>& from,
                            const std::vector<cv::Point2f>& start);

  MotionPriorParams params_;
  features::MotionOnlyBundleAdjustmentParams motion_ba_;
  OpticalFlow flow_;            ///< The map points' (seeds') flow.
  OpticalFlow candidate_flow_;  ///< The candidates' (MotionPriorParams::candidate_flow_window).
  cv::Mat shift_window_;        ///< The phase correlation's Hanning window, reused between frames.
};

}  // namespace scale_drift_slam::tracking
