#pragma once
// Camera images between sensor_msgs and the core: incoming images in any encoding the tracker
// accepts (raw or compressed), and the grey keyframe images that travel in Keyframe messages.
// The encoding checks are the core's (features/image_preparation.h), so the nodes and the
// offline runner accept and refuse the same images.

#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <opencv2/core.hpp>

#include "scale_drift_slam/features/image_preparation.h"

namespace scale_drift_slam::ros_conversions {

/// A camera image as the tracker takes it: pixels and their encoding.
struct CameraImage {
  cv::Mat image;
  features::PixelEncoding encoding = features::PixelEncoding::kMono8;
};

/// Copies the pixels of a sensor_msgs/Image (mono8, mono16, bgr8, rgb8, bgra8, rgba8 and the
/// 8UC1/16UC1/8UC3 aliases). Throws std::invalid_argument naming the encoding and the accepted
/// ones, or saying that the data is smaller than width, height and step announce.
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
