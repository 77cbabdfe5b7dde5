#include "scale_drift_slam/ros/pose_publisher.h"

#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>

#include "scale_drift_slam/ros/conversions.h"

namespace scale_drift_slam::ros_conversions {

PosePublisher::PosePublisher(ros::NodeHandle& nh, const TrackingNodeParams& params)
    : params_(params),
      odom_(params.map_z_up),
      path_(odom_.mapFromWorld(), params.frames.map,
            static_cast<std::size_t>(params.path_max_poses)) {
  odometry_pub_ = nh.advertise<nav_msgs::Odometry>("odometry", 10);
  path_pub_ = nh.advertise<nav_msgs::Path>("path", 1, true);
  if (params_.publish_optical_transform) {
    static_broadcaster_.sendTransform(toTransformStampedMsg(
        bodyFromOptical(), ros::Time(0), params_.frames.camera, params_.frames.optical));
  }
}

void PosePublisher::publish(const ros::Time& stamp, const geometry::SE3& T_cam_world,
                            std::optional<map::KeyframeId> reference_keyframe) {
  path_.add(stamp.toSec(), T_cam_world, reference_keyframe);
  const CameraTransforms t = odom_.transforms(T_cam_world);
  const FrameNames& f = params_.frames;
  broadcaster_.sendTransform({toTransformStampedMsg(t.T_map_odom, stamp, f.map, f.odom),
                              toTransformStampedMsg(t.T_odom_body, stamp, f.odom, f.camera)});
  nav_msgs::Odometry odometry;  // pose only: no covariance or twist is estimated
  odometry.header.stamp = stamp;
  odometry.header.frame_id = f.odom;
  odometry.child_frame_id = f.camera;
  odometry.pose.pose = toPoseMsg(t.T_odom_body);
  odometry_pub_.publish(odometry);
  if (++frames_since_path_ >= params_.path_publish_every) {
    frames_since_path_ = 0;
    path_pub_.publish(path_.message(stamp));
  }
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
}

}  // namespace scale_drift_slam::ros_conversions
