// The ROS layer's conversions: poses, similarities and CameraInfo survive a round trip, and a
// CameraInfo that describes no usable camera is refused with the reason.

#include <gtest/gtest.h>

#include "scale_drift_slam/ros/conversions.h"

namespace scale_drift_slam::ros_conversions {
namespace {

TEST(Conversions, PoseAndTransformRoundTrip) {
  geometry::SE3::Tangent xi;
  xi << 0.1, -0.7, 1.2, 3.0, -2.0, 0.5;
  const geometry::SE3 T = geometry::SE3::exp(xi);
  EXPECT_LT((fromPoseMsg(toPoseMsg(T)).matrix() - T.matrix()).norm(), 1e-15);
  EXPECT_LT((fromTransformMsg(toTransformMsg(T)).matrix() - T.matrix()).norm(), 1e-15);
  const geometry_msgs::TransformStamped stamped =
      toTransformStampedMsg(T, ros::Time(12.5), "map", "odom");
  EXPECT_EQ(stamped.header.frame_id, "map");
  EXPECT_EQ(stamped.child_frame_id, "odom");
  EXPECT_EQ(stamped.header.stamp.toSec(), 12.5);
  EXPECT_LT((fromTransformMsg(stamped.transform).matrix() - T.matrix()).norm(), 1e-15);
}

TEST(Conversions, Sim3RoundTripAndBadScale) {
  geometry::Sim3::Tangent xi;
  xi << 0.3, 0.2, -0.1, 0.99, 1.0, 2.0, 3.0;
  const geometry::Sim3 S = geometry::Sim3::exp(xi);
  EXPECT_LT((fromSim3Msg(toSim3Msg(S)).matrix() - S.matrix()).norm(), 1e-12);
  scale_drift_slam::Sim3 bad = toSim3Msg(S);
  bad.scale = 0.0;
  EXPECT_THROW(fromSim3Msg(bad), std::invalid_argument);
}

TEST(Conversions, CameraInfoRoundTripAndRefusals) {
  geometry::CameraCalibration c;
  c.fx = 458.654;
  c.fy = 457.296;
  c.cx = 367.215;
  c.cy = 248.375;
  c.width = 752;
  c.height = 480;
  c.distortion = {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05};
  const geometry::CameraCalibration back = calibrationFromCameraInfo(cameraInfoFromCalibration(c));
  EXPECT_EQ(back.fx, c.fx);
  EXPECT_EQ(back.cy, c.cy);
  EXPECT_EQ(back.width, c.width);
  EXPECT_EQ(back.distortion, c.distortion);

  sensor_msgs::CameraInfo uncalibrated;
  uncalibrated.width = 640;
  uncalibrated.height = 480;
  EXPECT_THROW(calibrationFromCameraInfo(uncalibrated), std::invalid_argument);
  sensor_msgs::CameraInfo nan_info = cameraInfoFromCalibration(c);
  nan_info.K[2] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(calibrationFromCameraInfo(nan_info), std::invalid_argument);
  sensor_msgs::CameraInfo unknown_model = cameraInfoFromCalibration(c);
  unknown_model.distortion_model = "rational_polynomial";
  EXPECT_THROW(calibrationFromCameraInfo(unknown_model), std::invalid_argument);
}

}  // namespace
}  // namespace scale_drift_slam::ros_conversions
