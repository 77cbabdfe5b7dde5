#pragma once
// The tracking node's pose outputs (doc/ros.md): tf (map -> odom -> base, the camera's mount
// base -> camera body read from tf or published when tf has none, the static camera body ->
// optical; with publish_odom_tf off only map -> odom, through the robot's odom -> base),
// nav_msgs/Odometry of the base with the motion-only BA's covariance and a twist, and
// nav_msgs/Path of every tracked frame corrected by loop closures. Owns the accumulated loop
// correction (OdomFrame) and the path, so that the node only hands it the tracker's poses.
// Camera thread only.

#include <memory>
#include <optional>
#include <string>

#include <ros/ros.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>

#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/geometry/sim3.h"
#include "scale_drift_slam/map/corrected_trajectory.h"
#include "scale_drift_slam/ros/frames.h"
#include "scale_drift_slam/ros/node_params.h"
#include "scale_drift_slam/ros/robot_frames.h"
#include "scale_drift_slam/ros/visualization.h"

namespace scale_drift_slam::ros_conversions {

class PosePublisher {
 public:
  /// Advertises "odometry" and "path" (latched) on nh; sends the static camera -> optical
  /// transform when params.publish_optical_transform; with a base frame, waits up to
  /// params.camera_mount_wait_s (wall time) for base -> camera on tf, else sends
  /// params.camera_mount as a static transform.
  PosePublisher(ros::NodeHandle& nh, const TrackingNodeParams& params);

  /// A tracked frame: adds it to the path, sends map -> odom and odom -> base (or only map ->
  /// odom through the robot's odom -> base), the odometry and, every params.path_publish_every
  /// frames, the path. `pose_information`: tracking::FrameResult::pose_information.
  void publish(const ros::Time& stamp, const geometry::SE3& T_cam_world,
               std::optional<map::KeyframeId> reference_keyframe,
               const Matrix6d& pose_information = Matrix6d::Zero());
  /// A loop correction of the tracker's map (MapUpdate::S_new_old): map -> odom and the whole
  /// path move; the path is published at once.
  void applyCorrection(const geometry::Sim3& S_new_old, const ros::Time& stamp);
  /// A new map: no correction, an empty path.
  void reset();

  /// The frames, for the map updates the tracker applies (CorrectedTrajectory::apply).
  map::CorrectedTrajectory& trajectory() { return path_.trajectory(); }
  /// The accumulated correction C (W_corrected <- W_odom).
  const geometry::Sim3& correction() const { return odom_.correction(); }

 private:
  /// T_body_base from tf, or params.camera_mount (then also sent on tf).
  void resolveMount();
  /// The robot's odom -> child at `stamp`, waiting up to params.odom_tf_timeout_s (wall time);
  /// empty (and a throttled warning) when tf cannot give it.
  std::optional<geometry::SE3> robotOdom(const ros::Time& stamp);
  void sendTransforms(const ros::Time& stamp, const CameraTransforms& t,
                      const geometry::SE3& T_map_child, const geometry::SE3& T_odom_child);
  void publishOdometry(const ros::Time& stamp, const geometry::SE3& T_map_child,
                       const geometry::SE3& T_odom_child, const Matrix6d& pose_information);

  const TrackingNodeParams& params_;
  std::string child_;           ///< The base, or the camera body when there is none.
  geometry::SE3 T_body_child_;  ///< camera body -> child (the inverse of the mount).
  tf2_ros::Buffer tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;  ///< Only when tf is read.
  struct Previous {  ///< The last published pose, for the twist.
    ros::Time stamp;
    geometry::SE3 T_odom_child;
    Matrix6d Sigma_child;
  };
  std::optional<Previous> previous_;
  OdomFrame odom_;
  CameraPath path_;
  int frames_since_path_ = 0;
  ros::Publisher odometry_pub_, path_pub_;
  tf2_ros::TransformBroadcaster broadcaster_;
  tf2_ros::StaticTransformBroadcaster static_broadcaster_;
};

}  // namespace scale_drift_slam::ros_conversions
