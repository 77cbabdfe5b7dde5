#include "scale_drift_slam/ros/image_conversions.h"

#include <algorithm>
#include <array>
#include <stdexcept>
#include <string>

#include <cv_bridge/cv_bridge.h>
#include <sensor_msgs/image_encodings.h>
#include <opencv2/imgcodecs.hpp>

namespace scale_drift_slam::ros_conversions {
namespace {

namespace encodings = sensor_msgs::image_encodings;

/// Encodings the core does not take, converted to mono8 by cv_bridge (demosaicing, the Y plane).
constexpr std::array<const char*, 5> kConvertedToMono8 = {"bayer_rggb8", "bayer_bggr8",
                                                          "bayer_gbrg8", "bayer_grbg8", "yuv422"};

bool convertedToMono8(const std::string& encoding) {
  return std::find(kConvertedToMono8.begin(), kConvertedToMono8.end(), encoding) !=
         kConvertedToMono8.end();
}

/// The core's encoding of the message as the tracker gets it; throws naming the accepted ones.
features::PixelEncoding coreEncodingOf(const std::string& encoding) {
  if (convertedToMono8(encoding)) return features::PixelEncoding::kMono8;
  try {
    return features::parsePixelEncoding(encoding);
  } catch (const std::invalid_argument& e) {
    std::string converted;
    for (const char* name : kConvertedToMono8)
      converted += (converted.empty() ? "" : ", ") + std::string(name);
    throw std::invalid_argument(std::string(e.what()) + "; also " + converted + " (as mono8)");
  }
}

/// cv_bridge wraps the data as width, height and step announce without checking its size: a
/// truncated message would be read past its end, so it is refused here first.
void checkImageData(const sensor_msgs::Image& msg) {
  if (msg.width == 0 || msg.height == 0) {
    throw std::invalid_argument("empty image (" + std::to_string(msg.width) + " x " +
                                std::to_string(msg.height) + ")");
  }
  const std::size_t row_bytes = static_cast<std::size_t>(msg.width) *
                                encodings::numChannels(msg.encoding) *
                                (encodings::bitDepth(msg.encoding) / 8);
  if (msg.step < row_bytes ||
      msg.data.size() < static_cast<std::size_t>(msg.step) * static_cast<std::size_t>(msg.height)) {
    throw std::invalid_argument("image data (" + std::to_string(msg.data.size()) + " bytes, step " +
                                std::to_string(msg.step) + ") is smaller than its " +
                                std::to_string(msg.width) + " x " + std::to_string(msg.height) +
                                " " + msg.encoding + " pixels");
  }
}

/// cv_bridge's view of the checked message: shared when `target` is empty (and the data is in
/// the machine's byte order), converted otherwise. cv_bridge reports problems as
/// cv_bridge::Exception and OpenCV's as cv::Exception (e.g. a 16-bit row step that is odd).
cv_bridge::CvImageConstPtr bridge(const sensor_msgs::Image& msg,
                                  const boost::shared_ptr<const void>& owner,
                                  const std::string& target) {
  try {
    return cv_bridge::toCvShare(msg, owner, target);
  } catch (const cv_bridge::Exception& e) {
    throw std::invalid_argument("cv_bridge cannot convert the " + msg.encoding +
                                " image: " + e.what());
  } catch (const cv::Exception& e) {
    throw std::invalid_argument("cv_bridge cannot read the " + msg.encoding +
                                " image: " + e.what());
  }
}

CameraImage convert(const sensor_msgs::Image& msg, const boost::shared_ptr<const void>& owner) {
  CameraImage result;
  result.encoding = coreEncodingOf(msg.encoding);  // refuses unknown encodings with the list
  checkImageData(msg);
  const cv_bridge::CvImageConstPtr bridged =
      bridge(msg, owner, convertedToMono8(msg.encoding) ? encodings::MONO8 : "");
  result.image = bridged->image;
  result.owner = bridged;
  const int expected = CV_MAKETYPE(encodings::bitDepth(bridged->encoding) == 16 ? CV_16U : CV_8U,
                                   encodings::numChannels(bridged->encoding));
  if (result.image.type() != expected &&
      result.image.elemSize() == static_cast<std::size_t>(CV_ELEM_SIZE(expected))) {
    // cv_bridge 1.16 swaps big-endian 16-bit data into the machine's order but returns it as
    // bytes (CV_8UC2; its reshape is discarded): view the swapped pixels as what they are.
    result.image = cv::Mat(result.image.rows, result.image.cols, expected, result.image.data,
                           result.image.step);
  }
  return result;
}

}  // namespace

CameraImage cameraImageFromMsg(const sensor_msgs::ImageConstPtr& msg) {
  return convert(*msg, msg);
}

CameraImage cameraImageFromMsg(const sensor_msgs::Image& msg) {
  CameraImage result = convert(msg, nullptr);
  // Pixels the image does not own (the message's, or cv_bridge's viewed as another type) are
  // copied: nothing keeps them alive once the owner goes.
  if (result.image.u == nullptr) result.image = result.image.clone();
  result.owner.reset();
  return result;
}

CameraImage cameraImageFromMsg(const sensor_msgs::CompressedImage& msg) {
  // Decoded by OpenCV itself: cv_bridge would guess the encoding from the format string, the
  // decoded image's type tells it exactly.
  CameraImage result;
  if (!msg.data.empty()) result.image = cv::imdecode(msg.data, cv::IMREAD_UNCHANGED);
  if (result.image.empty()) {
    throw std::invalid_argument("compressed image (format '" + msg.format + "', " +
                                std::to_string(msg.data.size()) + " bytes) cannot be decoded");
  }
  result.encoding = features::encodingOfMat(result.image);
  return result;
}

sensor_msgs::Image toMono8Msg(const cv::Mat& grey, const std_msgs::Header& header) {
  if (grey.type() != CV_8UC1) throw std::invalid_argument("a mono8 image must be CV_8UC1");
  sensor_msgs::Image msg;
  cv_bridge::CvImage(header, encodings::MONO8, grey).toImageMsg(msg);
  return msg;
}

sensor_msgs::Image toBgr8Msg(const cv::Mat& bgr, const std_msgs::Header& header) {
  if (bgr.type() != CV_8UC3) throw std::invalid_argument("a bgr8 image must be CV_8UC3");
  sensor_msgs::Image msg;
  cv_bridge::CvImage(header, encodings::BGR8, bgr).toImageMsg(msg);
  return msg;
}

cv::Mat fromMono8Msg(const sensor_msgs::Image& msg) {
  if (msg.encoding != encodings::MONO8 && msg.encoding != encodings::TYPE_8UC1) {
    throw std::invalid_argument("expected a mono8 image, got '" + msg.encoding + "'");
  }
  checkImageData(msg);
  return bridge(msg, nullptr, "")->image.clone();  // the keyframe outlives the message
}

}  // namespace scale_drift_slam::ros_conversions
