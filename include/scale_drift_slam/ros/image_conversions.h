#pragma once
// Camera images between sensor_msgs and the core: incoming images in any encoding the tracker
// accepts (raw or compressed), and the grey keyframe images that travel in Keyframe messages.
// Raw images go through cv_bridge: the core's encodings are shared as they are (no copy), and
// cv_bridge converts bayer and yuv422 images to mono8. The encoding checks are the core's
// (features/image_preparation.h), so the nodes and the offline runner accept and refuse the same
// images; cv_bridge's errors come back as std::invalid_argument with the reason.

#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <boost/shared_ptr.hpp>
#include <opencv2/core.hpp>

#include "scale_drift_slam/features/image_preparation.h"

namespace scale_drift_slam::ros_conversions {

/// A camera image as the tracker takes it: pixels and their encoding.
struct CameraImage {
  cv::Mat image;
  features::PixelEncoding encoding = features::PixelEncoding::kMono8;
  /// What keeps shared pixels alive (cv_bridge's image, which holds the message); null when
  /// `image` owns its pixels.
  boost::shared_ptr<const void> owner;
};

/// The encodings accepted in raw images: the core's (mono8, mono16, bgr8, rgb8, bgra8, rgba8
/// and the 8UC1/16UC1/8UC3/8UC4 aliases), and bayer_rggb8, bayer_bggr8, bayer_gbrg8, bayer_grbg8
/// and yuv422 (UYVY), which cv_bridge converts to mono8 (the tracker only uses grey).
/// The pixels of a sensor_msgs/Image, shared with the message when the core takes its encoding
/// (the result keeps the message alive), converted otherwise. Throws std::invalid_argument
/// naming the encoding and the accepted ones, or saying that the data is smaller than width,
/// height and step announce, or with cv_bridge's reason.
CameraImage cameraImageFromMsg(const sensor_msgs::ImageConstPtr& msg);
/// The same for a message without a shared pointer: the pixels are copied.
CameraImage cameraImageFromMsg(const sensor_msgs::Image& msg);
/// Decodes a sensor_msgs/CompressedImage (jpeg, png; 8 or 16 bit, grey or colour). Throws
/// std::invalid_argument when it cannot be decoded.
CameraImage cameraImageFromMsg(const sensor_msgs::CompressedImage& msg);

/// An 8-bit grey image (CV_8UC1) as a mono8 message with the given header. Throws
/// std::invalid_argument for another type.
sensor_msgs::Image toMono8Msg(const cv::Mat& grey, const std_msgs::Header& header);
/// A colour image (CV_8UC3, OpenCV's BGR order) as a bgr8 message. Throws std::invalid_argument
/// for another type.
sensor_msgs::Image toBgr8Msg(const cv::Mat& bgr, const std_msgs::Header& header);
/// A mono8 message as an 8-bit grey image (copied). Throws std::invalid_argument for another
/// encoding or too little data.
cv::Mat fromMono8Msg(const sensor_msgs::Image& msg);

}  // namespace scale_drift_slam::ros_conversions
