// What rviz gets: every map point in the cloud (in map coordinates), a frustum and a path vertex
// per keyframe, loop edges only when there are loops, and a debug image with the tracked points.

#include <gtest/gtest.h>
#include <sensor_msgs/point_cloud2_iterator.h>

#include "scale_drift_slam/ros/frames.h"
#include "scale_drift_slam/ros/visualization.h"

namespace scale_drift_slam::ros_visualization {
namespace {

map::Map smallMap() {
  map::Map m;
  m.addPoint({1, {0.0, 0.0, 2.0}, 0, {}});
  m.addPoint({2, {1.0, -1.0, 3.0}, 0, {}});
  for (map::KeyframeId id = 0; id < 3; ++id) {
    map::Keyframe k;
    k.id = id;
    k.T_kf_world = geometry::SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-0.1 * id, 0, 0));
    m.addKeyframe(k);
  }
  return m;
}

TEST(Visualization, CloudHoldsEveryPointInMapCoordinates) {
  const map::Map m = smallMap();
  std_msgs::Header header;
  header.frame_id = "map";
  const geometry::SE3 T_map_world = ros_frames::mapFromWorld(true);
  sensor_msgs::PointCloud2 cloud = mapCloud(m, T_map_world, header);
  EXPECT_EQ(cloud.header.frame_id, "map");
  ASSERT_EQ(cloud.width * cloud.height, 2u);
  std::vector<Eigen::Vector3d> points;
  for (sensor_msgs::PointCloud2ConstIterator<float> it(cloud, "x"); it != it.end(); ++it)
    points.emplace_back(it[0], it[1], it[2]);
  for (const auto& [id, point] : m.points()) {
    const Eigen::Vector3d expected = T_map_world * point.p_world;
    EXPECT_TRUE(std::any_of(points.begin(), points.end(), [&](const Eigen::Vector3d& p) {
      return (p - expected).norm() < 1e-6;
    }));
  }
  // Point (0, 0, 2) in front of the first camera is 2 ahead along map x.
  EXPECT_TRUE(std::any_of(points.begin(), points.end(), [](const Eigen::Vector3d& p) {
    return (p - Eigen::Vector3d(2, 0, 0)).norm() < 1e-6;
  }));
  EXPECT_EQ(mapCloud(map::Map(), T_map_world, header).width, 0u);
}

TEST(Visualization, KeyframeMarkersAndLoopEdges) {
  const map::Map m = smallMap();
  std_msgs::Header header;
  header.frame_id = "map";
  using visualization_msgs::Marker;
  const auto markers = keyframeMarkers(m, {}, geometry::SE3(), header, 0.1).markers;
  ASSERT_EQ(markers.size(), 3u);
  EXPECT_EQ(markers[0].ns, "keyframes");
  EXPECT_EQ(markers[0].points.size(), 3u * 16u);  // 8 lines per frustum
  EXPECT_EQ(markers[1].ns, "keyframe_path");
  ASSERT_EQ(markers[1].points.size(), 3u);
  EXPECT_NEAR(markers[1].points[2].x, 0.2, 1e-12);  // centre of keyframe 2
  EXPECT_EQ(markers[2].ns, "loop_edges");
  EXPECT_EQ(markers[2].action, Marker::DELETE);  // no loops yet
  const auto with_loop = keyframeMarkers(m, {{2, 0}, {5, 0}}, geometry::SE3(), header, 0.1);
  EXPECT_EQ(with_loop.markers[2].action, Marker::ADD);
  EXPECT_EQ(with_loop.markers[2].points.size(), 2u);  // the edge to an unknown keyframe is skipped
  EXPECT_EQ(deleteAllMarkers(header).markers[0].action, Marker::DELETEALL);
}

TEST(Visualization, DebugImageShowsTrackedPoints) {
  const cv::Mat grey(120, 160, CV_8UC1, cv::Scalar(100));
  tracking::FrameResult result;
  result.state = tracking::TrackingState::kGood;
  result.tracked_px = {{80.0, 90.0}};
  result.message = "hello";
  const cv::Mat image = debugImage(grey, result);
  ASSERT_EQ(image.type(), CV_8UC3);
  ASSERT_EQ(image.size(), grey.size());
  const cv::Vec3b on_circle = image.at<cv::Vec3b>(90, 84);            // radius 4
  EXPECT_GT(on_circle[1], on_circle[0] + 50);                         // green
  EXPECT_EQ(image.at<cv::Vec3b>(110, 10), cv::Vec3b(100, 100, 100));  // untouched background
}

}  // namespace
}  // namespace scale_drift_slam::ros_visualization
