#include "scale_drift_slam/ros/image_conversions.h"

#include <cstring>
#include <stdexcept>
#include <string>

#include <opencv2/imgcodecs.hpp>

namespace scale_drift_slam::ros_conversions {
namespace {

int matTypeOf(features::PixelEncoding encoding) {
  switch (encoding) {
    case features::PixelEncoding::kMono8:
      return CV_8UC1;
    case features::PixelEncoding::kMono16:
      return CV_16UC1;
    case features::PixelEncoding::kBgr8:
    case features::PixelEncoding::kRgb8:
      return CV_8UC3;
    case features::PixelEncoding::kBgra8:
    case features::PixelEncoding::kRgba8:
      return CV_8UC4;
  }
  return CV_8UC1;
}

/// Copies rows of `msg` into a new image of `type` after checking the announced sizes.
cv::Mat copyPixels(const sensor_msgs::Image& msg, int type) {
  const std::size_t row_bytes =
      static_cast<std::size_t>(msg.width) * static_cast<std::size_t>(CV_ELEM_SIZE(type));
  if (msg.width == 0 || msg.height == 0) {
    throw std::invalid_argument("empty image (" + std::to_string(msg.width) + " x " +
                                std::to_string(msg.height) + ")");
  }
  if (msg.step < row_bytes ||
      msg.data.size() < static_cast<std::size_t>(msg.step) * static_cast<std::size_t>(msg.height)) {
    throw std::invalid_argument("image data (" + std::to_string(msg.data.size()) + " bytes, step " +
                                std::to_string(msg.step) + ") is smaller than its " +
                                std::to_string(msg.width) + " x " + std::to_string(msg.height) +
                                " " + msg.encoding + " pixels");
  }
  cv::Mat image(static_cast<int>(msg.height), static_cast<int>(msg.width), type);
  for (int y = 0; y < image.rows; ++y) {
    std::memcpy(image.ptr(y), &msg.data[static_cast<std::size_t>(y) * msg.step], row_bytes);
  }
  if (CV_ELEM_SIZE1(type) == 2 && msg.is_bigendian) {
    // The wire order is big-endian: swap bytes into the machine's (little-endian) order.
    image.forEach<std::uint16_t>(
        [](std::uint16_t& v, const int*) { v = static_cast<std::uint16_t>((v >> 8) | (v << 8)); });
  }
  return image;
}

}  // namespace

CameraImage cameraImageFromMsg(const sensor_msgs::Image& msg) {
  CameraImage result;
  result.encoding = features::parsePixelEncoding(msg.encoding);  // names the accepted ones
  result.image = copyPixels(msg, matTypeOf(result.encoding));
  return result;
}

CameraImage cameraImageFromMsg(const sensor_msgs::CompressedImage& msg) {
  CameraImage result;
  if (!msg.data.empty()) result.image = cv::imdecode(msg.data, cv::IMREAD_UNCHANGED);
  if (result.image.empty()) {
    throw std::invalid_argument("compressed image (format '" + msg.format + "', " +
                                std::to_string(msg.data.size()) + " bytes) cannot be decoded");
  }
  result.encoding = features::encodingOfMat(result.image);
  return result;
}

namespace {

sensor_msgs::Image packedMsg(const cv::Mat& image, const std::string& encoding,
                             const std_msgs::Header& header) {
  sensor_msgs::Image msg;
  msg.header = header;
  msg.encoding = encoding;
  msg.width = static_cast<std::uint32_t>(image.cols);
  msg.height = static_cast<std::uint32_t>(image.rows);
  msg.step = static_cast<std::uint32_t>(image.cols * image.elemSize());
  msg.is_bigendian = 0;
  msg.data.resize(static_cast<std::size_t>(msg.step) * msg.height);
  for (int y = 0; y < image.rows; ++y) {
    std::memcpy(&msg.data[static_cast<std::size_t>(y) * msg.step], image.ptr(y), msg.step);
  }
  return msg;
}

}  // namespace

sensor_msgs::Image toMono8Msg(const cv::Mat& grey, const std_msgs::Header& header) {
  if (grey.type() != CV_8UC1) throw std::invalid_argument("a mono8 image must be CV_8UC1");
  return packedMsg(grey, "mono8", header);
}

sensor_msgs::Image toBgr8Msg(const cv::Mat& bgr, const std_msgs::Header& header) {
  if (bgr.type() != CV_8UC3) throw std::invalid_argument("a bgr8 image must be CV_8UC3");
  return packedMsg(bgr, "bgr8", header);
}

cv::Mat fromMono8Msg(const sensor_msgs::Image& msg) {
  if (msg.encoding != "mono8" && msg.encoding != "8UC1") {
    throw std::invalid_argument("expected a mono8 image, got '" + msg.encoding + "'");
  }
  return copyPixels(msg, CV_8UC1);
}

}  // namespace scale_drift_slam::ros_conversions
