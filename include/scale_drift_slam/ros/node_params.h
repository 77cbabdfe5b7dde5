#pragma once
// The nodes' parameters, read from the private namespace and validated in one place. Each node
// has a typed struct of its own settings; the SLAM's parameters are the core's
// system::SlamParams: the YAML file `~config` (config/default.yaml layout; defaults without it),
// then individual overrides `~<section>/<key>` (e.g. `~tracker/good_inliers: 40`,
// `~window_ba/window_size: 8`), parsed and validated by the core (io/slam_params_io.h). Any
// problem is a std::runtime_error naming the parameter, which the node reports with ROS_FATAL
// before it exits. doc/ros.md lists every parameter.

#include <optional>
#include <string>
#include <vector>

#include <ros/node_handle.h>
#include <xmlrpcpp/XmlRpcValue.h>

#include "scale_drift_slam/geometry/camera_calibration.h"
#include "scale_drift_slam/system/slam_params.h"

namespace scale_drift_slam::ros_conversions {

struct FrameNames {
  std::string map = "map";
  std::string odom = "odom";
  std::string camera = "camera_link";            ///< The camera body (x forward, z up).
  std::string optical = "camera_optical_frame";  ///< The camera optical frame (z forward).
  /// The robot's base (REP 105): odom -> base is published (or read), base -> camera is the
  /// camera's mount. Empty: no base, the camera body takes its place (odom -> camera).
  std::string base = "base_link";
};

/// tracking_node's own settings.
struct TrackingNodeParams {
  std::string config_file;       ///< SLAM parameters YAML; empty: the defaults.
  std::string calibration_file;  ///< Calibration YAML; empty: from CameraInfo.
  /// A rolling shutter's readout time (s), which CameraInfo cannot carry; > 0 sets it on the
  /// calibration, whichever its source (a calibration file may hold its own).
  double rolling_shutter_readout_s = 0.0;
  std::string transport = "raw";  ///< raw, compressed, or another installed image_transport plugin.
  int image_queue_size = 5;       ///< Images waiting while a frame is tracked (older are dropped).
  /// Keyframes roscpp keeps per subscriber while its connection stalls (a link outage: the
  /// oldest are dropped beyond this; doc/ros.md "Running on two machines").
  int keyframe_publish_queue_size = 200;
  FrameNames frames;
  bool map_z_up = true;  ///< map = the first camera's body axes (upright), else its optical axes.
  bool publish_optical_transform = true;  ///< Static camera -> optical transform.
  bool publish_tf = true;                 ///< map -> odom (and odom -> base) on tf.
  /// odom -> base on tf; false when the robot's odometry owns it: then only map -> odom, through
  /// the robot's odom -> base at the image's stamp (doc/ros.md, "tf on a robot").
  bool publish_odom_tf = true;
  /// The camera's mount base -> camera body, x y z [m] roll pitch yaw [rad] (as
  /// static_transform_publisher), published only when tf has none after camera_mount_wait_s.
  std::vector<double> camera_mount = std::vector<double>(6, 0.0);
  double camera_mount_wait_s = 2.0;  ///< Wall time to wait at start for the mount on tf.
  double odom_tf_timeout_s = 0.1;    ///< Wall time to wait for odom -> base at an image's stamp.
  /// Pixel noise (one sigma per coordinate) that scales the motion-only BA's (J^T J)^-1 into the
  /// nav_msgs/Odometry pose covariance.
  double pose_pixel_sigma_px = 1.0;
  int path_publish_every = 5;  ///< Frames between nav_msgs/Path messages.
  int path_max_poses = 20000;  ///< Oldest poses are dropped beyond this.
  /// An image stamped more than this before the previous one restarts tracking (a bag played
  /// again); a smaller step back (a driver glitch) only drops the image.
  double time_jump_restart_s = 1.0;
  /// A map file to start in (doc/map_file.md, "In ROS"): the tracker starts lost in it and
  /// relocalises by place recognition. Empty: a new map.
  std::string map_file;
  /// No keyframe is made: the loaded map does not change (needs map_file).
  bool localization_only = false;
  void validate() const;
};

/// mapping_node's own settings.
struct MappingNodeParams {
  std::string config_file;
  std::string map_frame = "map";
  bool map_z_up = true;           ///< Must match the tracking node's.
  std::string trajectory_file;    ///< Default path of ~save_trajectory.
  int keyframe_queue_size = 100;  ///< Keyframes waiting for the window BA.
  double marker_scale = 0.05;     ///< Keyframe frustum size in map units (median depth 1 at start).
  std::string map_file;           ///< A map file to start with (empty: a new map).
  std::string save_map_file;      ///< Default path of ~save_map.
  /// Where to save the map when the node shuts down: a path, or `true` for save_map_file (empty:
  /// not saved).
  std::string save_map_on_shutdown;
  void validate() const;
};

/// loop_closure_node's own settings (the camera comes with each keyframe: the tracker's own).
struct LoopClosureNodeParams {
  std::string config_file;
  int keyframe_queue_size = 100;  ///< roscpp queue of keyframes (the callback only hands them on).
  std::string map_file;           ///< A map file to start with (empty: a new map).
  void validate() const;
};

struct TrackingNodeConfig {
  TrackingNodeParams node;
  system::SlamParams slam;
  std::optional<geometry::CameraCalibration> calibration;  ///< From calibration_file.
  std::vector<std::string> unknown;  ///< Private parameters nobody reads (warned about).
};

struct MappingNodeConfig {
  MappingNodeParams node;
  system::SlamParams slam;
  std::vector<std::string> unknown;
};

struct LoopClosureNodeConfig {
  LoopClosureNodeParams node;
  system::SlamParams slam;  ///< Uses the loop_closure, loop_verification, place_recognition parts.
  std::vector<std::string> unknown;
};

/// Reads everything from the private namespace given as one XmlRpc struct (what
/// NodeHandle::getParam returns for the namespace). Throws std::runtime_error naming the
/// parameter: wrong type, invalid value, unreadable or invalid ~config or ~calibration_file.
TrackingNodeConfig trackingNodeConfig(const XmlRpc::XmlRpcValue& private_params);
MappingNodeConfig mappingNodeConfig(const XmlRpc::XmlRpcValue& private_params);
LoopClosureNodeConfig loopClosureNodeConfig(const XmlRpc::XmlRpcValue& private_params);
/// The SLAM parameters: ~config (or defaults), then the ~<section>/<key> overrides (place
/// recognition's nested keys as ~place_recognition/<group>/<key>, e.g.
/// ~place_recognition/appearance/max_features).
system::SlamParams slamParams(const XmlRpc::XmlRpcValue& private_params);

/// A parameter that is a path or a bool (~save_map_on_shutdown): true gives "true", false and
/// "false" give "". Throws for another kind of value.
std::string pathOrBool(const XmlRpc::XmlRpcValue& value);

/// All parameters of the node's private namespace (an empty struct when there are none).
XmlRpc::XmlRpcValue privateParams(const ros::NodeHandle& private_nh);

/// For the start-up log: every setting, one per line.
std::string describe(const TrackingNodeConfig& config);
std::string describe(const MappingNodeConfig& config);
std::string describe(const LoopClosureNodeConfig& config);

}  // namespace scale_drift_slam::ros_conversions
