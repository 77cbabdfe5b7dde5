#include "scale_drift_slam/ros/conversions.h"

#include <cmath>
#include <stdexcept>

#include <tf2_eigen/tf2_eigen.h>

namespace scale_drift_slam::ros_conversions {

geometry::CameraCalibration calibrationFromCameraInfo(const sensor_msgs::CameraInfo& info) {
  geometry::CameraCalibration calibration;
  if (info.K[0] == 0.0 && info.K[4] == 0.0) {
    throw std::invalid_argument(
        "CameraInfo has an all-zero camera matrix K: the camera is not calibrated");
  }
  calibration.model = geometry::parseDistortionModel(info.distortion_model);
  calibration.fx = info.K[0];
  calibration.cx = info.K[2];
  calibration.fy = info.K[4];
  calibration.cy = info.K[5];
  calibration.width = static_cast<int>(info.width);
  calibration.height = static_cast<int>(info.height);
  calibration.distortion = info.D;
  // Drivers often publish plumb_bob with five zeros, or an empty D: both mean no distortion.
  calibration.validate();
  return calibration;
}

sensor_msgs::CameraInfo cameraInfoFromCalibration(const geometry::CameraCalibration& c) {
  sensor_msgs::CameraInfo info;
  info.width = static_cast<uint32_t>(c.width);
  info.height = static_cast<uint32_t>(c.height);
  info.distortion_model = geometry::distortionModelName(c.model);
  info.D = c.distortion;
  if (c.model == geometry::DistortionModel::kRadialTangential && info.D.empty()) {
    info.D.assign(5, 0.0);
  }
  info.K = {c.fx, 0.0, c.cx, 0.0, c.fy, c.cy, 0.0, 0.0, 1.0};
  info.R = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
  info.P = {c.fx, 0.0, c.cx, 0.0, 0.0, c.fy, c.cy, 0.0, 0.0, 0.0, 1.0, 0.0};
  return info;
}

namespace {

// Eigen <-> geometry_msgs by tf2_eigen; the core's SE3 and Sim3 are assembled from the parts.
Eigen::Quaterniond fromQuaternionMsg(const geometry_msgs::Quaternion& msg) {
  Eigen::Quaterniond q;
  tf2::fromMsg(msg, q);
  return q;
}

template <typename Message>  // geometry_msgs::Point or Vector3
Eigen::Vector3d fromVectorMsg(const Message& msg) {
  Eigen::Vector3d v;
  tf2::fromMsg(msg, v);
  return v;
}

geometry_msgs::Vector3 toVector3Msg(const Eigen::Vector3d& v) {
  geometry_msgs::Vector3 msg;
  tf2::toMsg(v, msg);
  return msg;
}

}  // namespace

geometry_msgs::Pose toPoseMsg(const geometry::SE3& T) {
  geometry_msgs::Pose pose;
  pose.orientation = tf2::toMsg(T.rotation());
  pose.position = tf2::toMsg(T.translation());
  return pose;
}

geometry::SE3 fromPoseMsg(const geometry_msgs::Pose& pose) {
  return geometry::SE3(fromQuaternionMsg(pose.orientation), fromVectorMsg(pose.position));
}

geometry_msgs::Transform toTransformMsg(const geometry::SE3& T) {
  geometry_msgs::Transform transform;
  transform.rotation = tf2::toMsg(T.rotation());
  transform.translation = toVector3Msg(T.translation());
  return transform;
}

geometry::SE3 fromTransformMsg(const geometry_msgs::Transform& transform) {
  return geometry::SE3(fromQuaternionMsg(transform.rotation), fromVectorMsg(transform.translation));
}

geometry_msgs::TransformStamped toTransformStampedMsg(const geometry::SE3& T_parent_child,
                                                      const ros::Time& stamp,
                                                      const std::string& parent,
                                                      const std::string& child) {
  geometry_msgs::TransformStamped t;
  t.header.stamp = stamp;
  t.header.frame_id = parent;
  t.child_frame_id = child;
  t.transform = toTransformMsg(T_parent_child);
  return t;
}

scale_drift_slam::Sim3 toSim3Msg(const geometry::Sim3& S) {
  scale_drift_slam::Sim3 msg;
  msg.rotation = tf2::toMsg(S.rotation());
  msg.translation = toVector3Msg(S.translation());
  msg.scale = S.scale();
  return msg;
}

geometry::Sim3 fromSim3Msg(const scale_drift_slam::Sim3& msg) {
  if (!(msg.scale > 0.0) || !std::isfinite(msg.scale)) {
    throw std::invalid_argument("Sim3 message has a non-positive or non-finite scale (" +
                                std::to_string(msg.scale) + ")");
  }
  const geometry_msgs::Quaternion& q = msg.rotation;
  const double norm = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
  if (!std::isfinite(norm) || norm < 1e-6 || !std::isfinite(msg.translation.x) ||
      !std::isfinite(msg.translation.y) || !std::isfinite(msg.translation.z)) {
    throw std::invalid_argument(
        "Sim3 message has a non-finite translation or a non-finite or zero quaternion");
  }
  return geometry::Sim3::fromScale(fromQuaternionMsg(msg.rotation), fromVectorMsg(msg.translation),
                                   msg.scale);
}

}  // namespace scale_drift_slam::ros_conversions
