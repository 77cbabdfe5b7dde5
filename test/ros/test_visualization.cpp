// What rviz gets: every map point in the cloud (in map coordinates), a frustum and a path vertex
// per keyframe, loop edges only when there are loops, the camera path corrected with its
// keyframes, and a debug image with the tracked points.

#include <gtest/gtest.h>
#include <sensor_msgs/point_cloud2_iterator.h>

#include "scale_drift_slam/ros/frames.h"
#include "scale_drift_slam/ros/visualization.h"

namespace scale_drift_slam::ros_conversions {
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
  const geometry::SE3 T_map_world = ros_conversions::mapFromWorld(true);
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
  ASSERT_EQ(markers.size(), 4u);
  EXPECT_EQ(markers[0].ns, "keyframes");
  EXPECT_EQ(markers[0].points.size(), 3u * 16u);  // 8 lines per frustum
  EXPECT_EQ(markers[1].ns, "keyframe_path");
  ASSERT_EQ(markers[1].points.size(), 3u);
  EXPECT_NEAR(markers[1].points[2].x, 0.2, 1e-12);  // centre of keyframe 2
  EXPECT_EQ(markers[2].ns, "loop_edges");
  EXPECT_EQ(markers[2].action, Marker::DELETE);  // no loops yet
  EXPECT_EQ(markers[3].ns, "loop_edges");
  EXPECT_EQ(markers[3].id, 1);
  EXPECT_EQ(markers[3].action, Marker::DELETE);
  const auto with_loop = keyframeMarkers(m, {{2, 0}, {5, 0}}, geometry::SE3(), header, 0.1);
  EXPECT_EQ(with_loop.markers[2].action, Marker::ADD);
  EXPECT_EQ(with_loop.markers[2].points.size(), 2u);  // the edge to an unknown keyframe is skipped
  EXPECT_NEAR(with_loop.markers[2].points[0].x, 0.2, 1e-12);  // keyframe 2 to keyframe 0
  EXPECT_NEAR(with_loop.markers[2].points[1].x, 0.0, 1e-12);
  EXPECT_EQ(with_loop.markers[3].type, Marker::SPHERE_LIST);
  EXPECT_EQ(with_loop.markers[3].points.size(), 2u);
  EXPECT_DOUBLE_EQ(with_loop.markers[3].scale.z, 0.2);
  EXPECT_EQ(deleteAllMarkers(header).markers[0].action, Marker::DELETEALL);
}

TEST(Visualization, PathFollowsTheCorrectedTrajectory) {
  const geometry::SE3 T_map_world = ros_conversions::mapFromWorld(true);
  CameraPath path(T_map_world, "map", 3);
  for (int i = 0; i < 5; ++i) {
    // Cameras looking along the world z axis (optical), moving along x.
    path.add(1000.0 + i / 30.0,
             geometry::SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-0.1 * i, 0, 0)),
             i < 3 ? map::KeyframeId(0) : map::KeyframeId(1));
  }
  const nav_msgs::Path& msg = path.message(ros::Time(1001.0));
  ASSERT_EQ(msg.poses.size(), 3u);  // the newest three
  EXPECT_EQ(msg.header.frame_id, "map");
  EXPECT_EQ(msg.header.stamp, ros::Time(1001.0));
  EXPECT_NEAR(msg.poses[0].header.stamp.toSec(), 1000.0 + 2 / 30.0, 1e-9);
  // The optical z axis is the body x axis; the world x axis is map -y (map z up).
  const geometry_msgs::Pose p = msg.poses[2].pose;
  EXPECT_NEAR(p.position.x, 0.0, 1e-12);
  EXPECT_NEAR(p.position.y, -0.4, 1e-12);
  EXPECT_NEAR(p.orientation.w, 1.0, 1e-12);  // camera body aligned with map
  EXPECT_EQ(pathPose(path.trajectory().frames()[4].T_cam_world, 1000.0, T_map_world, "map").pose,
            p);

  // A loop correction moving keyframe 1's frames by 2 m along the world z axis: the path moves.
  map::MapUpdate loop;
  loop.S_new_old = geometry::Sim3();
  loop.keyframe_corrections.emplace_back(
      1, geometry::Sim3(geometry::SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, 2))));
  path.trajectory().apply(loop);
  path.rebuild();
  ASSERT_EQ(msg.poses.size(), 3u);
  EXPECT_NEAR(msg.poses[2].pose.position.x, 2.0, 1e-12);  // world z = map x
  EXPECT_NEAR(msg.poses[1].pose.position.x, 2.0, 1e-12);
  EXPECT_NEAR(msg.poses[0].pose.position.x, 0.0, 1e-12);  // keyframe 0's frames stay
  EXPECT_NEAR(msg.poses[0].pose.position.y, -0.2, 1e-12);
  for (int i = 0; i < 10; ++i)  // the trajectory is bounded too
    path.add(1001.0 + i, geometry::SE3(), 1);
  EXPECT_LE(path.trajectory().size(), 6u);
  EXPECT_EQ(path.message(ros::Time(1020.0)).poses.size(), 3u);
  path.clear();
  EXPECT_EQ(path.trajectory().size(), 0u);
  EXPECT_TRUE(path.message(ros::Time(1020.0)).poses.empty());
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
}  // namespace scale_drift_slam::ros_conversions
