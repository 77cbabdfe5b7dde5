// Camera images of every common encoding arrive as the tracker expects them (bayer and yuv422
// converted to grey by cv_bridge, the others shared with the message), compressed images
// are decoded, and anything else is refused with a reason that names the encoding.

#include <gtest/gtest.h>
#include <boost/make_shared.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "scale_drift_slam/ros/image_conversions.h"

namespace scale_drift_slam::ros_conversions {
namespace {

sensor_msgs::Image messageOf(const cv::Mat& image, const std::string& encoding, int padding = 0) {
  sensor_msgs::Image msg;
  msg.encoding = encoding;
  msg.width = static_cast<std::uint32_t>(image.cols);
  msg.height = static_cast<std::uint32_t>(image.rows);
  msg.step = static_cast<std::uint32_t>(image.cols * image.elemSize() + padding);
  msg.data.assign(static_cast<std::size_t>(msg.step) * msg.height, 0);
  for (int y = 0; y < image.rows; ++y) {
    std::memcpy(&msg.data[static_cast<std::size_t>(y) * msg.step], image.ptr(y),
                image.cols * image.elemSize());
  }
  return msg;
}

cv::Mat greyPattern() {
  cv::Mat grey(30, 40, CV_8UC1);
  cv::randu(grey, 0, 255);
  return grey;
}

TEST(ImageConversions, CommonEncodingsGiveTheSameGreyImage) {
  const cv::Mat grey = greyPattern();
  cv::Mat bgr, rgb, bgra, mono16;
  cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
  cv::cvtColor(grey, rgb, cv::COLOR_GRAY2RGB);
  cv::cvtColor(grey, bgra, cv::COLOR_GRAY2BGRA);
  grey.convertTo(mono16, CV_16UC1, 256.0);
  const std::vector<std::pair<sensor_msgs::Image, features::PixelEncoding>> cases = {
      {messageOf(grey, "mono8", 3), features::PixelEncoding::kMono8},
      {messageOf(grey, "8UC1"), features::PixelEncoding::kMono8},
      {messageOf(bgr, "bgr8"), features::PixelEncoding::kBgr8},
      {messageOf(rgb, "rgb8", 1), features::PixelEncoding::kRgb8},
      {messageOf(bgra, "bgra8"), features::PixelEncoding::kBgra8},
      {messageOf(mono16, "mono16"), features::PixelEncoding::kMono16}};
  for (const auto& [msg, encoding] : cases) {
    const CameraImage image = cameraImageFromMsg(msg);
    EXPECT_EQ(image.encoding, encoding) << msg.encoding;
    EXPECT_EQ(cv::norm(features::toGrey(image.image, image.encoding), grey, cv::NORM_INF), 0.0)
        << msg.encoding;
  }
  // mono16 in big-endian byte order.
  sensor_msgs::Image big = messageOf(mono16, "mono16");
  big.is_bigendian = 1;
  for (std::size_t i = 0; i + 1 < big.data.size(); i += 2)
    std::swap(big.data[i], big.data[i + 1]);
  const CameraImage swapped = cameraImageFromMsg(big);
  EXPECT_EQ(cv::norm(swapped.image, mono16, cv::NORM_INF), 0.0);
}

TEST(ImageConversions, OtherEncodingsAndBadDataAreRefusedWithTheReason) {
  const cv::Mat grey = greyPattern();
  for (const std::string encoding : {"32FC1", "bayer_rggb16", "yuv422_yuy2", "nv21", ""}) {
    try {
      cameraImageFromMsg(messageOf(grey, encoding));
      FAIL() << encoding << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("'" + encoding + "'"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("mono8"), std::string::npos) << e.what();
    }
  }
  sensor_msgs::Image truncated = messageOf(grey, "mono8");
  truncated.data.resize(truncated.data.size() - 1);
  EXPECT_THROW(cameraImageFromMsg(truncated), std::invalid_argument);
  sensor_msgs::Image short_step = messageOf(grey, "bgr8");  // 1 byte per pixel announced as 3
  EXPECT_THROW(cameraImageFromMsg(short_step), std::invalid_argument);
  EXPECT_THROW(cameraImageFromMsg(sensor_msgs::Image()), std::invalid_argument);
}

TEST(ImageConversions, BayerAndYuv422AreConvertedToGreyByCvBridge) {
  // A flat colour: every Bayer cell and every UYVY pixel pair gives the same grey level.
  cv::Mat bayer(30, 40, CV_8UC1);
  for (int y = 0; y < bayer.rows; ++y) {
    for (int x = 0; x < bayer.cols; ++x)  // RGGB: R at (even, even), B at (odd, odd), G else
      bayer.at<std::uint8_t>(y, x) = y % 2 == 0 && x % 2 == 0 ? 200 : y % 2 && x % 2 ? 40 : 120;
  }
  const CameraImage from_bayer = cameraImageFromMsg(messageOf(bayer, "bayer_rggb8", 2));
  EXPECT_EQ(from_bayer.encoding, features::PixelEncoding::kMono8);
  ASSERT_EQ(from_bayer.image.type(), CV_8UC1);
  ASSERT_EQ(from_bayer.image.size(), bayer.size());
  const cv::Rect inner(2, 2, bayer.cols - 4, bayer.rows - 4);  // demosaicing borders differ
  double low, high;
  cv::minMaxLoc(from_bayer.image(inner), &low, &high);
  EXPECT_LE(high - low, 1.0);
  EXPECT_NEAR(low, 0.299 * 200 + 0.587 * 120 + 0.114 * 40, 2.0);  // the luma of (200, 120, 40)

  cv::Mat uyvy(30, 40, CV_8UC2);
  const cv::Mat luma = greyPattern();
  for (int y = 0; y < uyvy.rows; ++y) {
    for (int x = 0; x < uyvy.cols; ++x)  // U Y0 V Y1: chroma, then the pixel's luma
      uyvy.at<cv::Vec2b>(y, x) = {static_cast<std::uint8_t>(x % 2 ? 140 : 110),
                                  luma.at<std::uint8_t>(y, x)};
  }
  const CameraImage from_yuv = cameraImageFromMsg(messageOf(uyvy, "yuv422"));
  EXPECT_EQ(from_yuv.encoding, features::PixelEncoding::kMono8);
  EXPECT_EQ(cv::norm(from_yuv.image, luma, cv::NORM_INF), 0.0);  // the Y plane as it is

  sensor_msgs::Image truncated = messageOf(uyvy, "yuv422");
  truncated.data.resize(truncated.data.size() / 2);
  EXPECT_THROW(cameraImageFromMsg(truncated), std::invalid_argument);
}

TEST(ImageConversions, SharedPointerMessagesAreNotCopied) {
  const cv::Mat grey = greyPattern();
  const auto msg = boost::make_shared<sensor_msgs::Image>(messageOf(grey, "mono8", 3));
  CameraImage image = cameraImageFromMsg(sensor_msgs::ImageConstPtr(msg));
  EXPECT_EQ(image.image.data, msg->data.data());
  EXPECT_EQ(cv::norm(image.image, grey, cv::NORM_INF), 0.0);
  // The image keeps the message alive; a message passed by reference is copied.
  EXPECT_TRUE(image.owner);
  EXPECT_NE(cameraImageFromMsg(*msg).image.data, msg->data.data());
}

TEST(ImageConversions, CompressedImagesAreDecoded) {
  const cv::Mat grey = greyPattern();
  sensor_msgs::CompressedImage png;
  png.format = "mono8; png compressed";
  cv::imencode(".png", grey, png.data);
  const CameraImage decoded = cameraImageFromMsg(png);
  EXPECT_EQ(decoded.encoding, features::PixelEncoding::kMono8);
  EXPECT_EQ(cv::norm(decoded.image, grey, cv::NORM_INF), 0.0);
  cv::Mat bgr;
  cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
  sensor_msgs::CompressedImage jpeg;
  jpeg.format = "bgr8; jpeg compressed bgr8";
  cv::imencode(".jpg", bgr, jpeg.data);
  EXPECT_EQ(cameraImageFromMsg(jpeg).encoding, features::PixelEncoding::kBgr8);
  sensor_msgs::CompressedImage garbage;
  garbage.format = "jpeg";
  garbage.data = {1, 2, 3, 4};
  EXPECT_THROW(cameraImageFromMsg(garbage), std::invalid_argument);
}

TEST(ImageConversions, Mono8RoundTrip) {
  const cv::Mat grey = greyPattern();
  std_msgs::Header header;
  header.frame_id = "cam";
  const sensor_msgs::Image msg = toMono8Msg(grey, header);
  EXPECT_EQ(msg.header.frame_id, "cam");
  EXPECT_EQ(cv::norm(fromMono8Msg(msg), grey, cv::NORM_INF), 0.0);
  EXPECT_THROW(toMono8Msg(cv::Mat(3, 3, CV_8UC3), header), std::invalid_argument);
  cv::Mat bgr(4, 5, CV_8UC3);
  cv::randu(bgr, 0, 255);
  const sensor_msgs::Image colour = toBgr8Msg(bgr, header);
  EXPECT_EQ(colour.encoding, "bgr8");
  const CameraImage back = cameraImageFromMsg(colour);
  EXPECT_EQ(cv::norm(back.image, bgr, cv::NORM_INF), 0.0);
  EXPECT_THROW(toBgr8Msg(grey, header), std::invalid_argument);
}

}  // namespace
}  // namespace scale_drift_slam::ros_conversions
