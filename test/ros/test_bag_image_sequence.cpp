// The bag reader of run_sequence on hostile bags (issue 17): an image message whose data is
// shorter than its size is rejected with that reason before cv_bridge sees it, images of another
// size than the CameraInfo are reported once, and a truncated bag's error suggests
// `rosbag reindex`.

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include "scale_drift_slam/ros/bag_image_sequence.h"
#include "scale_drift_slam/ros/conversions.h"

namespace scale_drift_slam::ros_conversions {
namespace {

sensor_msgs::Image imageMessage(double stamp, int width, int height, std::size_t bytes) {
  sensor_msgs::Image image;
  image.header.stamp = ros::Time(stamp);
  image.width = width;
  image.height = height;
  image.encoding = "mono8";
  image.step = width;
  image.data.assign(bytes, 100);
  return image;
}

std::string writeBag(const std::string& name) {
  const std::string path = ::testing::TempDir() + "/" + name;
  geometry::CameraCalibration calibration;
  calibration.width = 64;
  calibration.height = 48;
  calibration.fx = calibration.fy = 50;
  calibration.cx = 32;
  calibration.cy = 24;
  rosbag::Bag bag(path, rosbag::bagmode::Write);
  sensor_msgs::CameraInfo info = cameraInfoFromCalibration(calibration);
  info.header.stamp = ros::Time(1.0);
  bag.write("/camera/camera_info", ros::Time(1.0), info);
  bag.write("/camera/image_raw", ros::Time(1.0), imageMessage(1.0, 64, 48, 64 * 48));
  bag.write("/camera/image_raw", ros::Time(1.1), imageMessage(1.1, 64, 48, 100));  // short
  bag.write("/camera/image_raw", ros::Time(1.2), imageMessage(1.2, 32, 24, 32 * 24));
  bag.write("/camera/image_raw", ros::Time(1.3), imageMessage(1.3, 32, 24, 32 * 24));
  bag.close();
  return path;
}

TEST(BagImageSequence, ShortMessagesAndOtherSizesAreReported) {
  const std::string path = writeBag("sds_hostile_images.bag");
  const auto sequence = openBagImageSequence(path, "/camera/image_raw", "/camera/camera_info");
  ASSERT_TRUE(sequence->calibration().has_value());
  const auto good = sequence->next();
  ASSERT_TRUE(good.has_value());
  EXPECT_EQ(good->image.cols, 64);
  EXPECT_TRUE(good->problem.empty());
  const auto shorter = sequence->next();
  ASSERT_TRUE(shorter.has_value());
  EXPECT_TRUE(shorter->image.empty());
  EXPECT_NE(shorter->problem.find("holds 100 bytes: too few for its size"), std::string::npos)
      << shorter->problem;
  EXPECT_TRUE(sequence->warnings().empty());
  EXPECT_EQ(sequence->next()->image.cols, 32);
  EXPECT_EQ(sequence->next()->image.cols, 32);
  EXPECT_FALSE(sequence->next().has_value());
  ASSERT_EQ(sequence->warnings().size(), 1u);  // once, not per frame
  EXPECT_NE(sequence->warnings()[0].find("images are 32x24 but its CameraInfo is 64x48"),
            std::string::npos)
      << sequence->warnings()[0];
}

TEST(BagImageSequence, ATruncatedBagSuggestsReindex) {
  const std::string path = writeBag("sds_to_truncate.bag");
  const std::string truncated = ::testing::TempDir() + "/sds_truncated.bag";
  {
    std::ifstream in(path, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(truncated, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  }
  try {
    openBagImageSequence(truncated, "/camera/image_raw", "/camera/camera_info");
    FAIL() << "a truncated bag was opened";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("rosbag reindex " + truncated), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace scale_drift_slam::ros_conversions
