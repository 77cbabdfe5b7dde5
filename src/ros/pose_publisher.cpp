#include "scale_drift_slam/ros/pose_publisher.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>

#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <tf2/exceptions.h>

#include "scale_drift_slam/features/motion_only_bundle_adjustment.h"
#include "scale_drift_slam/ros/conversions.h"

namespace scale_drift_slam::ros_conversions {
namespace {

/// The variance (rad^2, map units^2) published where nothing is known: the pose came not from
/// the motion-only BA (map initialisation) or there is no previous pose for the twist.
constexpr double kUnknownVariance = 1e6;
/// Consecutive poses further apart than this give no twist (tracking was lost in between).
constexpr double kMaxTwistGapS = 1.0;

void copyCovariance(const Matrix6d& covariance, boost::array<double, 36>* out) {
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c)
      (*out)[6 * r + c] = covariance(r, c);
  }
}

std::string describePose(const geometry::SE3& T) {
  const Eigen::Vector3d t = T.translation();
  const Eigen::Matrix3d R = T.rotationMatrix();  // R = Rz(yaw) Ry(pitch) Rx(roll)
  const double roll = std::atan2(R(2, 1), R(2, 2));
  const double pitch = std::asin(std::clamp(-R(2, 0), -1.0, 1.0));
  const double yaw = std::atan2(R(1, 0), R(0, 0));
  char text[160];
  std::snprintf(text, sizeof(text), "xyz [%.4f, %.4f, %.4f] rpy [%.4f, %.4f, %.4f]", t.x(), t.y(),
                t.z(), roll, pitch, yaw);
  return text;
}

}  // namespace

PosePublisher::PosePublisher(ros::NodeHandle& nh, const TrackingNodeParams& params)
    : params_(params),
      child_(params.frames.base.empty() ? params.frames.camera : params.frames.base),
      odom_(params.map_z_up),
      path_(odom_.mapFromWorld(), params.frames.map,
            static_cast<std::size_t>(params.path_max_poses)) {
  odometry_pub_ = nh.advertise<nav_msgs::Odometry>("odometry", 10);
  path_pub_ = nh.advertise<nav_msgs::Path>("path", 1, true);
  if (params_.publish_optical_transform) {
    static_broadcaster_.sendTransform(toTransformStampedMsg(
        bodyFromOptical(), ros::Time(0), params_.frames.camera, params_.frames.optical));
  }
  if (!params_.frames.base.empty() || (params_.publish_tf && !params_.publish_odom_tf)) {
    tf_listener_ = std::make_unique<tf2_ros::TransformListener>(tf_buffer_);
  }
  if (!params_.frames.base.empty()) resolveMount();
  if (!params_.publish_tf || params_.publish_odom_tf) {
    tf_listener_.reset();  // the mount is read once: no need to follow /tf any more
  } else {
    ROS_INFO("publish_odom_tf is off: publishing only %s -> %s, through the robot's %s -> %s",
             params_.frames.map.c_str(), params_.frames.odom.c_str(), params_.frames.odom.c_str(),
             child_.c_str());
  }
}

void PosePublisher::resolveMount() {
  const FrameNames& f = params_.frames;
  const ros::WallTime deadline =
      ros::WallTime::now() + ros::WallDuration(params_.camera_mount_wait_s);
  std::string error;
  while (ros::ok()) {
    try {
      const geometry::SE3 T_base_body =
          fromTransformMsg(tf_buffer_.lookupTransform(f.base, f.camera, ros::Time(0)).transform);
      T_body_child_ = T_base_body.inverse();
      ROS_INFO("camera mount %s -> %s from tf: %s", f.base.c_str(), f.camera.c_str(),
               describePose(T_base_body).c_str());
      return;
    } catch (const tf2::TransformException& e) {
      error = e.what();
    }
    if (ros::WallTime::now() > deadline) break;
    ros::WallDuration(0.05).sleep();
  }
  const std::vector<double>& m = params_.camera_mount;
  const geometry::SE3 T_base_body = fromXyzRpy(m[0], m[1], m[2], m[3], m[4], m[5]);
  T_body_child_ = T_base_body.inverse();
  static_broadcaster_.sendTransform(
      toTransformStampedMsg(T_base_body, ros::Time(0), f.base, f.camera));
  ROS_WARN(
      "no camera mount %s -> %s on tf after %.1f s (%s): publishing ~camera_mount %s as a static "
      "transform (give the URDF / robot_state_publisher or a static_transform_publisher for the "
      "real one)",
      f.base.c_str(), f.camera.c_str(), params_.camera_mount_wait_s, error.c_str(),
      describePose(T_base_body).c_str());
}

std::optional<geometry::SE3> PosePublisher::robotOdom(const ros::Time& stamp) {
  const FrameNames& f = params_.frames;
  const ros::WallTime deadline =
      ros::WallTime::now() + ros::WallDuration(params_.odom_tf_timeout_s);
  std::string error;
  while (ros::ok()) {
    try {
      return fromTransformMsg(tf_buffer_.lookupTransform(f.odom, child_, stamp).transform);
    } catch (const tf2::TransformException& e) {
      error = e.what();
    }
    if (ros::WallTime::now() > deadline) break;
    ros::WallDuration(0.005).sleep();
  }
  ROS_WARN_THROTTLE(5,
                    "no %s -> %s on tf at the image's stamp %.6f (%s): %s -> %s not published "
                    "for this frame",
                    f.odom.c_str(), child_.c_str(), stamp.toSec(), error.c_str(), f.map.c_str(),
                    f.odom.c_str());
  return std::nullopt;
}

void PosePublisher::publish(const ros::Time& stamp, const geometry::SE3& T_cam_world,
                            std::optional<map::KeyframeId> reference_keyframe,
                            const Matrix6d& pose_information) {
  path_.add(stamp.toSec(), T_cam_world, reference_keyframe);
  const CameraTransforms t = odom_.transforms(T_cam_world);
  const geometry::SE3 T_map_child = t.T_map_body * T_body_child_;
  const geometry::SE3 T_odom_child = t.T_odom_body * T_body_child_;
  if (params_.publish_tf) sendTransforms(stamp, t, T_map_child, T_odom_child);
  publishOdometry(stamp, T_map_child, T_odom_child, pose_information);
  if (++frames_since_path_ >= params_.path_publish_every) {
    frames_since_path_ = 0;
    path_pub_.publish(path_.message(stamp));
  }
}

void PosePublisher::sendTransforms(const ros::Time& stamp, const CameraTransforms& t,
                                   const geometry::SE3& T_map_child,
                                   const geometry::SE3& T_odom_child) {
  const FrameNames& f = params_.frames;
  if (params_.publish_odom_tf) {
    broadcaster_.sendTransform({toTransformStampedMsg(t.T_map_odom, stamp, f.map, f.odom),
                                toTransformStampedMsg(T_odom_child, stamp, f.odom, child_)});
    return;
  }
  if (const std::optional<geometry::SE3> T_robot_odom_child = robotOdom(stamp)) {
    broadcaster_.sendTransform(
        toTransformStampedMsg(mapFromOdom(T_map_child, *T_robot_odom_child), stamp, f.map, f.odom));
  }
}

void PosePublisher::publishOdometry(const ros::Time& stamp, const geometry::SE3& T_map_child,
                                    const geometry::SE3& T_odom_child,
                                    const Matrix6d& pose_information) {
  // In our odom frame while we own it; in map when the robot's odometry owns odom.
  const bool in_odom = params_.publish_odom_tf;
  nav_msgs::Odometry odometry;
  odometry.header.stamp = stamp;
  odometry.header.frame_id = in_odom ? params_.frames.odom : params_.frames.map;
  odometry.child_frame_id = child_;
  const geometry::SE3& T_parent_child = in_odom ? T_odom_child : T_map_child;
  odometry.pose.pose = toPoseMsg(T_parent_child);
  // The camera's covariance (optical frame) carried to the child, then into ROS' layout.
  const std::optional<Matrix6d> Sigma_optical =
      features::poseCovariance(pose_information, params_.pose_pixel_sigma_px);
  const Matrix6d Sigma_child =
      Sigma_optical
          ? attachedCovariance(*Sigma_optical, bodyFromOptical().inverse() * T_body_child_)
          : Matrix6d(Matrix6d::Identity() * kUnknownVariance);
  const double scale = in_odom ? 1.0 / odom_.correction().scale() : 1.0;
  copyCovariance(Sigma_optical ? rosPoseCovariance(Sigma_child, T_parent_child, scale)
                               : Matrix6d(Matrix6d::Identity() * kUnknownVariance),
                 &odometry.pose.covariance);
  // The twist from the continuous (odom) poses: loop corrections do not jump it.
  const double dt = previous_ ? (stamp - previous_->stamp).toSec() : 0.0;
  if (previous_ && dt > 0.0 && dt <= kMaxTwistGapS) {
    const BodyTwist twist = twistBetween(previous_->T_odom_child, T_odom_child, dt);
    odometry.twist.twist.linear.x = twist.linear.x();
    odometry.twist.twist.linear.y = twist.linear.y();
    odometry.twist.twist.linear.z = twist.linear.z();
    odometry.twist.twist.angular.x = twist.angular.x();
    odometry.twist.twist.angular.y = twist.angular.y();
    odometry.twist.twist.angular.z = twist.angular.z();
    // Sigma_child is in map units; the twist in odom units (1/s of them after a correction).
    Matrix6d twist_covariance = twistCovariance(previous_->Sigma_child, Sigma_child, dt);
    const double odom_scale = 1.0 / odom_.correction().scale();
    twist_covariance.topRows<3>() *= odom_scale;
    twist_covariance.leftCols<3>() *= odom_scale;
    copyCovariance(twist_covariance, &odometry.twist.covariance);
  } else {
    copyCovariance(Matrix6d::Identity() * kUnknownVariance, &odometry.twist.covariance);
  }
  previous_ = Previous{stamp, T_odom_child, Sigma_child};
  odometry_pub_.publish(odometry);
}

void PosePublisher::applyCorrection(const geometry::Sim3& S_new_old, const ros::Time& stamp) {
  odom_.applyCorrection(S_new_old);
  path_.rebuild();
  path_pub_.publish(path_.message(stamp));
  frames_since_path_ = 0;
}

void PosePublisher::reset() {
  odom_.reset();
  path_.clear();
  previous_.reset();
}

}  // namespace scale_drift_slam::ros_conversions
