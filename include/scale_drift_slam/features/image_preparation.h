#pragma once
// Turning a camera image, in whatever encoding it arrives, into the 8-bit grey image pyramid the
// front-end works on. ROS-free: encodings are named by the strings of sensor_msgs/Image
// ("mono8", "bgr8", ...) but parsed into an enum here. Undistortion is not done on the image:
// features are found in the raw image and undistorted as coordinates through the camera model
// (geometry/camera_model.h), which costs nothing per pixel and keeps the image noise untouched.

#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace scale_drift_slam::features {

class FastCornerCache;

/// Pixel layouts accepted from cameras and bags (sensor_msgs/image_encodings names).
enum class PixelEncoding { kMono8, kMono16, kBgr8, kRgb8, kBgra8, kRgba8 };

/// Parses "mono8", "mono16", "bgr8", "rgb8", "bgra8", "rgba8" (also "8UC1" = mono8, "16UC1" =
/// mono16, "8UC3" = bgr8). Throws std::invalid_argument naming the accepted encodings.
PixelEncoding parsePixelEncoding(const std::string& name);
std::string pixelEncodingName(PixelEncoding encoding);
/// The encoding of an OpenCV image by its type: CV_8UC1 mono8, CV_16UC1 mono16, CV_8UC3 bgr8,
/// CV_8UC4 bgra8 (OpenCV's own channel order). Throws std::invalid_argument for other types.
PixelEncoding encodingOfMat(const cv::Mat& image);

/// An 8-bit grey copy of `image`, read as `encoding`. mono16 holding `mono16_bits` bits of data
/// (8..16; 12 for a 12-bit camera) is scaled by 1 / 2^(bits - 8), larger values saturate.
/// Throws std::invalid_argument when the image is empty or its type does not match the encoding
/// (a 3-channel image announced as mono8, a 16-bit image announced as bgr8), or for bits
/// outside [8, 16].
cv::Mat toGrey(const cv::Mat& image, PixelEncoding encoding, int mono16_bits = 16);
/// The bits the values of a 16-bit image use: 8..16 (16-bit PNGs from a 12-bit camera hold
/// values below 4096: 12, or fewer for a dark frame). Throws std::invalid_argument for another
/// type.
int significantBits(const cv::Mat& mono16);

/// A grey image and its pyramid: level 0 is the image itself, each further level halves it
/// (cv::pyrDown, Gaussian 5x5). Levels stop early when the image gets smaller than 32 pixels.
/// Every level is an ROI inside a padded buffer, as cv::calcOpticalFlowPyrLK wants it.
struct ImagePyramid {
  std::vector<cv::Mat> levels;
  /// The same levels of the photometrically normalised image (normalisePhotometry), which the
  /// optical flow follows points in when it is on; empty: the flow uses `levels`.
  std::vector<cv::Mat> flow_levels;
  const std::vector<cv::Mat>& flowLevels() const {
    return flow_levels.empty() ? levels : flow_levels;
  }
  /// Scharr gradients (CV_16SC2: d/dx, d/dy) of flowLevels(), padded alike. Built once with the
  /// pyramid: cv::calcOpticalFlowPyrLK would otherwise compute them again on every call (three
  /// or four calls per frame, 0.4 ms each at 1241x376). May be empty.
  std::vector<cv::Mat> flow_gradients;
  /// The first `num_levels` flow levels as cv::calcOpticalFlowPyrLK takes a pyramid: each level
  /// followed by its gradient when they were built.
  std::vector<cv::Mat> lucasKanadePyramid(int num_levels) const;
  /// The base level alone as cv::calcOpticalFlowPyrLK takes a one-level pyramid: followed by
  /// its gradient when one was built for it (not for the normalised flow levels), so that the
  /// call does not compute it again. Empty when the padding is narrower than `window` (the call
  /// then needs the bare image, which it pads itself).
  std::vector<cv::Mat> baseLevelForLucasKanade(int window) const;
  /// FAST corners of the base level, detected once and shared by the copies of this pyramid
  /// (set by buildPyramid).
  std::shared_ptr<FastCornerCache> fast_corners;
  /// fast_corners, or a new cache of base() for a pyramid put together by hand.
  std::shared_ptr<FastCornerCache> corners() const;
  const cv::Mat& base() const { return levels.front(); }
  int numLevels() const { return static_cast<int>(levels.size()); }
};

/// Builds the pyramid of a CV_8UC1 image with at most `num_levels` levels (>= 1), each padded by
/// `padding` pixels (at least the optical-flow window). Throws std::invalid_argument for an empty
/// or non-grey image.
/// With `photometric_radius` > 0 it also builds `flow_levels`: normalisePhotometry of each
/// level, padded alike.
ImagePyramid buildPyramid(const cv::Mat& grey, int num_levels, int padding = 21,
                          int photometric_radius = 0);

/// Local photometric normalisation for the optical flow: each pixel's difference from the mean
/// of the (2 radius + 1)^2 box around it over that box's mean absolute deviation (at least 6 grey
/// levels, so that flat areas and their noise stay flat), mapped to 128 + 26 x. Lucas-Kanade
/// assumes that a point keeps its grey level; vignetting (a smooth gain that changes as the point
/// crosses the image), a changing exposure and light that varies over the scene break that, and
/// the flow is then pulled along the patch's grey-level gradient: a bias of a fraction of a pixel
/// per frame, the same for every point in one part of the image. A smooth gain and offset cancel
/// here.
cv::Mat normalisePhotometry(const cv::Mat& grey, int radius);

/// Stretches a low-contrast frame: when the range between its 1st and 99th grey-level
/// percentiles is below `target_range`, the grey values are scaled by
/// min(max_gain, target_range / range) about that range's centre, then moved just enough to keep
/// the scaled range inside 0-255 (not to mid-grey: the map tends to the identity as the range
/// nears the target, so a frame whose range hovers about it is not shifted on and off by tens of
/// grey levels, which the optical flow between two frames cannot follow).
/// Why: a dark or washed-out frame (a camera still adapting its exposure, a dim scene) holds
/// the same structure as a well-exposed one at a fraction of the grey levels, and the corner
/// detectors' thresholds are absolute; the cap keeps sensor noise (and fixed-pattern noise in
/// saturated areas) from being blown up into texture. Frames with a wider range are unchanged,
/// so are black and uniform ones (range 0: nothing to stretch). Returns the gain applied (1 when
/// unchanged). Throws std::invalid_argument for a non-grey image, target_range outside (0, 255]
/// or max_gain < 1.
double stretchContrast(cv::Mat* grey, double target_range, double max_gain);

/// Why a frame cannot be used, or "" when it can: empty, a size other than the calibration's,
/// or (after grey conversion) without texture (the standard deviation of the grey values below
/// `min_contrast`, e.g. a black or blank frame).
std::string frameProblem(const cv::Mat& grey, int expected_width, int expected_height,
                         double min_contrast);

}  // namespace scale_drift_slam::features
