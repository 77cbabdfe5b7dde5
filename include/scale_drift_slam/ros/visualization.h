#pragma once
// What the nodes show in rviz, built from core data: the map as a point cloud, keyframes and loop
// edges as markers (mapping node), and the tracking node's debug image. Drawing only; every
// position is taken from the map or the frame result as it is. Points and poses are brought from
// the SLAM world into `map` by T_map_world (ros_frames::mapFromWorld).

#include <utility>
#include <vector>

#include <sensor_msgs/PointCloud2.h>
#include <visualization_msgs/MarkerArray.h>
#include <opencv2/core.hpp>

#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/map/map.h"
#include "scale_drift_slam/tracking/tracker.h"

namespace scale_drift_slam::ros_visualization {

/// Every map point as x, y, z (float32) in the header's frame.
sensor_msgs::PointCloud2 mapCloud(const map::Map& map, const geometry::SE3& T_map_world,
                                  const std_msgs::Header& header);

/// Namespaces "keyframes" (a small camera frustum per keyframe, LINE_LIST), "keyframe_path"
/// (keyframe centres in id order, LINE_STRIP) and "loop_edges" (one line per loop constraint
/// between keyframe centres, LINE_LIST); a namespace with nothing to show is deleted.
/// `frustum_size` is the frustum depth in map units.
visualization_msgs::MarkerArray keyframeMarkers(
    const map::Map& map, const std::vector<std::pair<map::KeyframeId, map::KeyframeId>>& loops,
    const geometry::SE3& T_map_world, const std_msgs::Header& header, double frustum_size);

/// Removes all markers (after a reset).
visualization_msgs::MarkerArray deleteAllMarkers(const std_msgs::Header& header);

/// A colour image of the frame: the grey frame with the tracked map points (green circles) and a
/// line of text (state, inliers, matches, time, message).
cv::Mat debugImage(const cv::Mat& grey, const tracking::FrameResult& result);

}  // namespace scale_drift_slam::ros_visualization
