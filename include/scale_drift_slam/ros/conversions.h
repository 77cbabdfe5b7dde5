#pragma once
// Conversions between ROS messages and core types, shared by the nodes and the tools. The only
// place where message layouts meet the core's classes.

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/Transform.h>
#include <geometry_msgs/TransformStamped.h>
#include <sensor_msgs/CameraInfo.h>

#include "scale_drift_slam/Sim3.h"
#include "scale_drift_slam/geometry/camera_calibration.h"
#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/geometry/sim3.h"

namespace scale_drift_slam::ros_conversions {

/// A CameraInfo as a core calibration. Throws std::invalid_argument with the reason when the
/// message describes no usable camera (all-zero K of an uncalibrated driver, an unknown
/// distortion model, NaN entries).
geometry::CameraCalibration calibrationFromCameraInfo(const sensor_msgs::CameraInfo& info);
sensor_msgs::CameraInfo cameraInfoFromCalibration(const geometry::CameraCalibration& calibration);

geometry_msgs::Pose toPoseMsg(const geometry::SE3& T);
geometry::SE3 fromPoseMsg(const geometry_msgs::Pose& pose);
geometry_msgs::Transform toTransformMsg(const geometry::SE3& T);
geometry::SE3 fromTransformMsg(const geometry_msgs::Transform& transform);
/// T_parent_child as a tf message (maps child-frame points into the parent frame).
geometry_msgs::TransformStamped toTransformStampedMsg(const geometry::SE3& T_parent_child,
                                                      const ros::Time& stamp,
                                                      const std::string& parent,
                                                      const std::string& child);
scale_drift_slam::Sim3 toSim3Msg(const geometry::Sim3& S);
/// Throws std::invalid_argument for a non-positive or non-finite scale, a non-finite translation
/// or a non-finite or zero quaternion.
geometry::Sim3 fromSim3Msg(const scale_drift_slam::Sim3& msg);

}  // namespace scale_drift_slam::ros_conversions
