#pragma once
// The tracking node's pose outputs (doc/ros.md): tf (map -> odom -> camera body, and the static
// camera body -> optical), nav_msgs/Odometry in odom, and nav_msgs/Path of every tracked frame
// corrected by loop closures. Owns the accumulated loop correction (OdomFrame) and the path, so
// that the node only hands it the tracker's poses. Camera thread only.

#include <optional>

#include <ros/ros.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>

#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/geometry/sim3.h"
#include "scale_drift_slam/map/corrected_trajectory.h"
#include "scale_drift_slam/ros/frames.h"
#include "scale_drift_slam/ros/node_params.h"
#include "scale_drift_slam/ros/visualization.h"

namespace scale_drift_slam::ros_conversions {

class PosePublisher {
 public:
  /// Advertises "odometry" and "path" (latched) on nh; sends the static camera -> optical
  /// transform when params.publish_optical_transform.
  PosePublisher(ros::NodeHandle& nh, const TrackingNodeParams& params);

  /// A tracked frame: adds it to the path, sends map -> odom and odom -> camera body, the
  /// odometry and, every params.path_publish_every frames, the path.
  void publish(const ros::Time& stamp, const geometry::SE3& T_cam_world,
               std::optional<map::KeyframeId> reference_keyframe);
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
  const TrackingNodeParams& params_;
  OdomFrame odom_;
  CameraPath path_;
  int frames_since_path_ = 0;
  ros::Publisher odometry_pub_, path_pub_;
  tf2_ros::TransformBroadcaster broadcaster_;
  tf2_ros::StaticTransformBroadcaster static_broadcaster_;
};

}  // namespace scale_drift_slam::ros_conversions
