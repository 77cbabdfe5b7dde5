#include "scale_drift_slam/ros/conversions.h"

#include <cmath>
#include <stdexcept>

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

geometry_msgs::Quaternion toQuaternionMsg(const Eigen::Quaterniond& q) {
  geometry_msgs::Quaternion msg;
  msg.x = q.x();
  msg.y = q.y();
  msg.z = q.z();
  msg.w = q.w();
  return msg;
}

Eigen::Quaterniond fromQuaternionMsg(const geometry_msgs::Quaternion& msg) {
  return Eigen::Quaterniond(msg.w, msg.x, msg.y, msg.z);
}

}  // namespace

geometry_msgs::Pose toPoseMsg(const geometry::SE3& T) {
  geometry_msgs::Pose pose;
  pose.orientation = toQuaternionMsg(T.rotation());
  pose.position.x = T.translation().x();
  pose.position.y = T.translation().y();
  pose.position.z = T.translation().z();
  return pose;
}

geometry::SE3 fromPoseMsg(const geometry_msgs::Pose& pose) {
  return geometry::SE3(fromQuaternionMsg(pose.orientation),
                       Eigen::Vector3d(pose.position.x, pose.position.y, pose.position.z));
}

geometry_msgs::Transform toTransformMsg(const geometry::SE3& T) {
  geometry_msgs::Transform transform;
  transform.rotation = toQuaternionMsg(T.rotation());
  transform.translation.x = T.translation().x();
  transform.translation.y = T.translation().y();
  transform.translation.z = T.translation().z();
  return transform;
}

geometry::SE3 fromTransformMsg(const geometry_msgs::Transform& transform) {
  return geometry::SE3(
      fromQuaternionMsg(transform.rotation),
      Eigen::Vector3d(transform.translation.x, transform.translation.y, transform.translation.z));
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
  msg.rotation = toQuaternionMsg(S.rotation());
  msg.translation.x = S.translation().x();
  msg.translation.y = S.translation().y();
  msg.translation.z = S.translation().z();
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
  return geometry::Sim3::fromScale(
      fromQuaternionMsg(msg.rotation),
      Eigen::Vector3d(msg.translation.x, msg.translation.y, msg.translation.z), msg.scale);
}

}  // namespace scale_drift_slam::ros_conversions
