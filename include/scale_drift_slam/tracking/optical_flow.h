#pragma once
// Optical flow from the previous frame to the current one, the source of the motion prior
// (doc/algorithm.md, "Front-end: tracking one frame", step 1: the paper used dense variational
// flow on a GPU). Two methods behind one call, chosen by accuracy per millisecond
// (doc/frontend.md, bench_motion_prior): pyramidal Lucas-Kanade at the given points (default)
// and OpenCV's dense DIS flow sampled at the points. Not thread-safe (DIS keeps state); one per
// tracker.

#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/video/tracking.hpp>

#include "scale_drift_slam/features/image_preparation.h"

namespace scale_drift_slam::tracking {

enum class FlowMethod { kLucasKanade, kDis };
/// "lucas_kanade" (or "lk") and "dis". Throws std::invalid_argument otherwise.
FlowMethod parseFlowMethod(const std::string& name);
std::string flowMethodName(FlowMethod method);

struct OpticalFlowParams {
  FlowMethod method = FlowMethod::kLucasKanade;
  int window = 11;          ///< Lucas-Kanade window (pixels, odd).
  int pyramid_levels = 4;   ///< Levels used by Lucas-Kanade (1 = no pyramid).
  int max_iterations = 20;  ///< Lucas-Kanade iterations per level.
  /// Lucas-Kanade stops iterating at a level once its step is below this (pixels of that level).
  /// 0.03 px saves 12 % of the flow's time on renders without losing accuracy, but it (and 10
  /// iterations) lost frames on real sequences (doc/frontend.md): kept at OpenCV's usual 0.01.
  double min_step_px = 0.01;
  double max_error = 30.0;  ///< Lucas-Kanade: drop points whose mean patch error is larger.
  /// Drop points whose backward flow misses the start by more than this (pixels); <= 0 skips the
  /// backward check (it doubles the cost).
  double max_forward_backward_px = 0.0;
  int dis_preset = 0;  ///< DIS: 0 ultrafast, 1 fast, 2 medium.
  /// Lucas-Kanade follows points in the photometrically normalised image
  /// (features::normalisePhotometry) with this box radius (pixels); 0: in the image itself.
  int photometric_radius = 0;
  /// When its pose is weak, the motion prior measures the whole image's shift (imageShift); when
  /// that differs from where the flow started (the median predicted displacement) by more than
  /// this (pixels), the points are tracked again from their positions moved by the shift, and the
  /// prior keeps whichever set of tracks gives the pose with more inliers: a jerk of the hand or
  /// a low frame rate moves the image further than Lucas-Kanade's pyramid reaches from where the
  /// motion was expected, and a start out of reach can converge onto the wrong texture (0: never).
  double shift_retry_px = 20.0;
  void validate() const;
};

/// The whole image's translation from `previous` to `current` in pixels of level 0: phase
/// correlation at the finest level at most 160 px wide (`window` caches its Hanning window).
cv::Point2d imageShift(const features::ImagePyramid& previous,
                       const features::ImagePyramid& current, cv::Mat* window);

class OpticalFlow {
 public:
  explicit OpticalFlow(const OpticalFlowParams& params);

  /// Moves `from` (pixels in `previous`) into `current`; `ok[i]` says whether point i was
  /// tracked (inside the image, converged, consistent). Outputs have the size of `from`.
  /// `start`, when given (same size), is where Lucas-Kanade starts each point instead of at
  /// `from` (a predicted position); a point that fails from there is tried again from `from`.
  void track(const features::ImagePyramid& previous, const features::ImagePyramid& current,
             const std::vector<cv::Point2f>& from, std::vector<cv::Point2f>* to,
             std::vector<unsigned char>* ok, const std::vector<cv::Point2f>* start = nullptr);

  /// Clears `ok[i]` where the backward Lucas-Kanade flow from `to[i]` (in `current`) misses
  /// `from[i]` (in `previous`) by more than `max_px` pixels, whatever the forward method.
  void checkBackward(const features::ImagePyramid& previous, const features::ImagePyramid& current,
                     const std::vector<cv::Point2f>& from, const std::vector<cv::Point2f>& to,
                     std::vector<unsigned char>* ok, double max_px) const;

  const OpticalFlowParams& params() const { return params_; }

 private:
  void trackLucasKanade(const features::ImagePyramid& previous,
                        const features::ImagePyramid& current, const std::vector<cv::Point2f>& from,
                        const std::vector<cv::Point2f>* start, std::vector<cv::Point2f>* to,
                        std::vector<unsigned char>* ok) const;
  /// One Lucas-Kanade pass; `to` holds the start positions when `from_start` is set.
  /// `previous` and `current` as ImagePyramid::lucasKanadePyramid gives them, `levels` deep.
  void lucasKanadePass(const std::vector<cv::Mat>& previous, const std::vector<cv::Mat>& current,
                       int levels, const std::vector<cv::Point2f>& from, bool from_start,
                       std::vector<cv::Point2f>* to, std::vector<unsigned char>* ok) const;
  /// checkBackward on pyramids as lucasKanadePass takes them; only tracks with `ok` set are
  /// followed back.
  void dropBackwardMisses(const std::vector<cv::Mat>& previous, const std::vector<cv::Mat>& current,
                          int levels, const std::vector<cv::Point2f>& from,
                          const std::vector<cv::Point2f>& to, std::vector<unsigned char>* ok,
                          double max_px) const;
  void trackDis(const features::ImagePyramid& previous, const features::ImagePyramid& current,
                const std::vector<cv::Point2f>& from, std::vector<cv::Point2f>* to,
                std::vector<unsigned char>* ok);

  OpticalFlowParams params_;
  cv::Ptr<cv::DISOpticalFlow> dis_;
  cv::Mat flow_;  ///< DIS output, reused between frames.
};

}  // namespace scale_drift_slam::tracking
