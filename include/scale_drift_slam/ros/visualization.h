#pragma once
// What the nodes show in rviz, built from core data: the map as a point cloud, keyframes and loop
// edges as markers (mapping node), the camera path and the tracking node's debug image. Drawing
// only; every position is taken from the map or the frame result as it is. Points and poses are
// brought from the SLAM world into `map` by T_map_world (ros_conversions::mapFromWorld).

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <geometry_msgs/PoseStamped.h>
#include <nav_msgs/Path.h>
#include <sensor_msgs/PointCloud2.h>
#include <visualization_msgs/MarkerArray.h>
#include <opencv2/core.hpp>

#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/map/corrected_trajectory.h"
#include "scale_drift_slam/map/map.h"
#include "scale_drift_slam/ros/image_conversions.h"
#include "scale_drift_slam/tracking/tracker.h"

namespace scale_drift_slam::ros_conversions {

/// Every map point as x, y, z (float32) in the header's frame.
sensor_msgs::PointCloud2 mapCloud(const map::Map& map, const geometry::SE3& T_map_world,
                                  const std_msgs::Header& header);

/// Namespaces "keyframes" (a small camera frustum per keyframe, LINE_LIST), "keyframe_path"
/// (keyframe centres in id order, LINE_STRIP) and "loop_edges" (id 0: one line per loop
/// constraint between keyframe centres, LINE_LIST; id 1: a ball on each keyframe a loop joins,
/// SPHERE_LIST); a marker with nothing to show is deleted.
/// `frustum_size` is the frustum depth in map units.
visualization_msgs::MarkerArray keyframeMarkers(
    const map::Map& map, const std::vector<std::pair<map::KeyframeId, map::KeyframeId>>& loops,
    const geometry::SE3& T_map_world, const std_msgs::Header& header, double frustum_size);

/// A tracked frame as a path pose: the camera body (REP 103, camera_link) in `map_frame`,
/// T_map_world T_cam_world^-1 T_optical_body, stamped with the frame's time.
geometry_msgs::PoseStamped pathPose(const geometry::SE3& T_cam_world, double timestamp,
                                    const geometry::SE3& T_map_world, const std::string& map_frame);

/// The tracking node's nav_msgs/Path: every tracked frame kept in the corrected world
/// (map::CorrectedTrajectory), the newest `max_poses` of them in the message, which grows by one
/// pose per frame and is rebuilt after a loop correction so that the whole history moves with its
/// keyframes instead of keeping a jump. Tracking thread only.
class CameraPath {
 public:
  CameraPath(const geometry::SE3& T_map_world, std::string map_frame, std::size_t max_poses);
  void add(double timestamp, const geometry::SE3& T_cam_world,
           std::optional<map::KeyframeId> reference_keyframe);
  /// The frames, for the map updates the tracker applies (CorrectedTrajectory::apply).
  map::CorrectedTrajectory& trajectory() { return trajectory_; }
  /// The message again from the frames as they are now (after a loop correction).
  void rebuild();
  void clear();
  /// The message, stamped.
  const nav_msgs::Path& message(const ros::Time& stamp);

 private:
  geometry::SE3 T_map_world_;
  std::size_t max_poses_;
  map::CorrectedTrajectory trajectory_;  ///< At most 2 max_poses frames.
  nav_msgs::Path path_;
};

/// Removes all markers (after a reset).
visualization_msgs::MarkerArray deleteAllMarkers(const std_msgs::Header& header);

/// A colour image of the frame: the grey frame with the tracked map points (green circles) and a
/// line of text (state, inliers, matches, time, message).
cv::Mat debugImage(const cv::Mat& grey, const tracking::FrameResult& result);
/// The debug image of a frame as a bgr8 message: the header's stamp in `frame_id`.
sensor_msgs::Image debugImageMsg(const CameraImage& image, const tracking::FrameResult& result,
                                 const std_msgs::Header& header, const std::string& frame_id);

}  // namespace scale_drift_slam::ros_conversions
