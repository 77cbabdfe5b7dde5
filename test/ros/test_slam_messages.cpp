// The SLAM messages survive the trip through ROS messages: a keyframe, a map update, a loop
// constraint and the relocalisation request and answer come back as the core made them (map
// update points to float32 precision), the tracking status carries the frame's verdict, and
// malformed messages are refused with the reason.

#include <limits>

#include <gtest/gtest.h>

#include "scale_drift_slam/ros/slam_messages.h"

namespace scale_drift_slam::ros_conversions {
namespace {

geometry::SE3 somePose(double a) {
  geometry::SE3::Tangent xi;
  xi << 0.1 * a, -0.2, 0.3, 1.0 + a, -2.0, 0.5;
  return geometry::SE3::exp(xi);
}

map::KeyframeMessage someKeyframe() {
  map::KeyframeMessage k;
  k.keyframe.id = 17;
  k.keyframe.timestamp = 1234.5;
  k.keyframe.T_kf_world = somePose(1.0);
  k.keyframe.observations = {{3, {0.1, -0.2}}, {40, {0.123456789012345, 0.5}}};
  k.new_points = {{40, {1.0, 2.0, 3.000000001}, 17}, {41, {-1.0, 0.5, 7.0}, 16}};
  k.earlier_observations = {{12, 40, {0.3, 0.4}}, {15, 41, {-0.25, 0.125}}};
  k.map_version = 12345678901234ull;
  k.image = cv::Mat(48, 64, CV_8UC1);
  cv::randu(k.image, 0, 255);
  return k;
}

TEST(SlamMessages, KeyframeRoundTripIsExact) {
  const map::KeyframeMessage k = someKeyframe();
  const scale_drift_slam::Keyframe msg = toKeyframeMsg(k);
  EXPECT_EQ(msg.image.encoding, "mono8");
  EXPECT_EQ(msg.header.stamp.toSec(), 1234.5);
  const map::KeyframeMessage back = fromKeyframeMsg(msg);
  EXPECT_EQ(back.keyframe.id, k.keyframe.id);
  EXPECT_EQ(back.keyframe.timestamp, k.keyframe.timestamp);
  EXPECT_LT((back.keyframe.T_kf_world.matrix() - k.keyframe.T_kf_world.matrix()).norm(), 1e-15);
  ASSERT_EQ(back.keyframe.observations.size(), 2u);
  EXPECT_EQ(back.keyframe.observations[1].point_id, 40u);
  EXPECT_EQ(back.keyframe.observations[1].xy, k.keyframe.observations[1].xy);
  ASSERT_EQ(back.new_points.size(), 2u);
  EXPECT_EQ(back.new_points[0].p_world, k.new_points[0].p_world);
  EXPECT_EQ(back.new_points[1].reference_keyframe, 16u);
  ASSERT_EQ(back.earlier_observations.size(), 2u);
  EXPECT_EQ(back.earlier_observations[1].keyframe_id, 15u);
  EXPECT_EQ(back.earlier_observations[1].point_id, 41u);
  EXPECT_EQ(back.earlier_observations[1].xy, k.earlier_observations[1].xy);
  EXPECT_EQ(back.map_version, k.map_version);
  ASSERT_EQ(back.image.type(), CV_8UC1);
  EXPECT_EQ(cv::norm(back.image, k.image, cv::NORM_INF), 0.0);
}

TEST(SlamMessages, MalformedKeyframesAreRefused) {
  scale_drift_slam::Keyframe msg = toKeyframeMsg(someKeyframe());
  scale_drift_slam::Keyframe nan_pose = msg;
  nan_pose.T_kf_world.position.y = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(fromKeyframeMsg(nan_pose), std::invalid_argument);
  scale_drift_slam::Keyframe zero_rotation = msg;
  zero_rotation.T_kf_world.orientation = geometry_msgs::Quaternion();
  zero_rotation.T_kf_world.orientation.w = 0.0;
  EXPECT_THROW(fromKeyframeMsg(zero_rotation), std::invalid_argument);
  scale_drift_slam::Keyframe nan_point = msg;
  nan_point.new_points[1].position.z = std::numeric_limits<double>::infinity();
  EXPECT_THROW(fromKeyframeMsg(nan_point), std::invalid_argument);
  scale_drift_slam::Keyframe colour = msg;
  colour.image.encoding = "bgr8";
  EXPECT_THROW(fromKeyframeMsg(colour), std::invalid_argument);
  scale_drift_slam::Keyframe truncated = msg;
  truncated.image.data.resize(10);
  EXPECT_THROW(fromKeyframeMsg(truncated), std::invalid_argument);
  scale_drift_slam::Keyframe no_image = msg;
  no_image.image = sensor_msgs::Image();
  EXPECT_TRUE(fromKeyframeMsg(no_image).image.empty());

  // Receivers that can do without the image take the keyframe and hear why the image is unusable.
  std::string problem = "stale";
  EXPECT_FALSE(fromKeyframeMsg(msg, &problem).image.empty());
  EXPECT_EQ(problem, "");
  const map::KeyframeMessage without = fromKeyframeMsg(colour, &problem);
  EXPECT_TRUE(without.image.empty());
  EXPECT_EQ(without.keyframe.id, 17u);
  EXPECT_NE(problem.find("bgr8"), std::string::npos) << problem;
  EXPECT_TRUE(fromKeyframeMsg(truncated, &problem).image.empty());
  EXPECT_FALSE(problem.empty());
  EXPECT_THROW(fromKeyframeMsg(nan_point, &problem), std::invalid_argument);  // not the image
}

TEST(SlamMessages, MapUpdateRoundTrip) {
  map::MapUpdate u;
  u.map_version = 99;
  geometry::Sim3::Tangent xi;
  xi << 0.02, -0.01, 0.03, 0.2, 0.5, -0.4, 0.1;
  u.S_new_old = geometry::Sim3::exp(xi);
  u.keyframe_poses = {{3, somePose(0.5)}, {4, somePose(-0.5)}};
  u.point_positions = {{7, {1.25, -2.5, 10.0}}, {8, {0.1, 0.2, 0.3}}};
  u.removed_points = {5, 6};
  u.culled_keyframes = {2, 9};
  u.keyframe_corrections = {{3, geometry::Sim3::exp(0.5 * xi)}, {4, *u.S_new_old}};
  u.loop_links = {{4, 0}, {90, 12}};
  const map::MapUpdate back = fromMapUpdateMsg(toMapUpdateMsg(u));
  EXPECT_EQ(back.map_version, 99u);
  ASSERT_TRUE(back.S_new_old.has_value());
  EXPECT_LT((back.S_new_old->matrix() - u.S_new_old->matrix()).norm(), 1e-12);
  ASSERT_EQ(back.keyframe_poses.size(), 2u);
  EXPECT_EQ(back.keyframe_poses[1].first, 4u);
  EXPECT_LT((back.keyframe_poses[1].second.matrix() - u.keyframe_poses[1].second.matrix()).norm(),
            1e-15);
  ASSERT_EQ(back.point_positions.size(), 2u);
  EXPECT_EQ(back.point_positions[0].first, 7u);
  // Points travel as float32: relative precision 2^-24.
  EXPECT_LT((back.point_positions[0].second - u.point_positions[0].second).norm(), 1e-6);
  EXPECT_LT((back.point_positions[1].second - u.point_positions[1].second).norm(), 1e-7);
  EXPECT_EQ(back.removed_points, u.removed_points);
  EXPECT_EQ(back.culled_keyframes, u.culled_keyframes);
  ASSERT_EQ(back.keyframe_corrections.size(), 2u);
  EXPECT_EQ(back.keyframe_corrections[0].first, 3u);
  EXPECT_LT(
      (back.keyframe_corrections[0].second.matrix() - u.keyframe_corrections[0].second.matrix())
          .norm(),
      1e-12);
  EXPECT_EQ(back.loop_links, u.loop_links);

  map::MapUpdate window;  // a window BA result carries no correction
  window.map_version = 5;
  window.keyframe_poses = {{1, somePose(1.0)}};
  const scale_drift_slam::MapUpdate msg = toMapUpdateMsg(window);
  EXPECT_FALSE(msg.has_loop_correction);
  EXPECT_FALSE(fromMapUpdateMsg(msg).S_new_old.has_value());
}

TEST(SlamMessages, MalformedMapUpdatesAreRefused) {
  map::MapUpdate u;
  u.keyframe_poses = {{1, somePose(1.0)}};
  u.point_positions = {{2, {1.0, 2.0, 3.0}}};
  const scale_drift_slam::MapUpdate msg = toMapUpdateMsg(u);
  scale_drift_slam::MapUpdate lengths = msg;
  lengths.point_ids.push_back(3);
  EXPECT_THROW(fromMapUpdateMsg(lengths), std::invalid_argument);
  scale_drift_slam::MapUpdate nan_point = msg;
  nan_point.point_positions[0].x = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(fromMapUpdateMsg(nan_point), std::invalid_argument);
  scale_drift_slam::MapUpdate bad_scale = msg;
  bad_scale.has_loop_correction = true;
  bad_scale.S_new_old.scale = -1.0;
  EXPECT_THROW(fromMapUpdateMsg(bad_scale), std::invalid_argument);
  scale_drift_slam::MapUpdate links = msg;
  links.loop_link_from.push_back(3);
  EXPECT_THROW(fromMapUpdateMsg(links), std::invalid_argument);
}

loop::LoopConstraint someConstraint() {
  loop::LoopConstraint c;
  c.current_id = 95;
  c.loop_id = 2;
  c.T_current_loop = somePose(0.3);
  c.scale = 1.0873;
  c.S_current_loop = geometry::Sim3::fromScale(c.T_current_loop.rotation(),
                                               c.scale * c.T_current_loop.translation(), c.scale);
  c.num_matches = 180;
  c.num_inliers = 131;
  c.num_scale_pairs = 64;
  c.rmse_px = 0.71;
  return c;
}

TEST(SlamMessages, LoopConstraintRoundTrip) {
  const loop::LoopConstraint c = someConstraint();
  const scale_drift_slam::Sim3Constraint msg = toSim3ConstraintMsg(c);
  EXPECT_EQ(msg.from_keyframe_id, 95u);
  EXPECT_EQ(msg.to_keyframe_id, 2u);
  EXPECT_DOUBLE_EQ(msg.measurement.scale, 1.0873);
  for (int r = 0; r < 7; ++r) {
    for (int k = 0; k < 7; ++k)
      EXPECT_EQ(msg.information[7 * r + k], r == k ? 1.0 : 0.0);
  }
  const loop::LoopConstraint back = fromSim3ConstraintMsg(msg);
  EXPECT_EQ(back.current_id, 95u);
  EXPECT_EQ(back.loop_id, 2u);
  EXPECT_LT((back.S_current_loop.matrix() - c.S_current_loop.matrix()).norm(), 1e-12);
  EXPECT_LT((back.T_current_loop.matrix() - c.T_current_loop.matrix()).norm(), 1e-12);
  EXPECT_DOUBLE_EQ(back.scale, c.scale);
  EXPECT_EQ(back.num_matches, 180);
  EXPECT_EQ(back.num_inliers, 131);
  EXPECT_EQ(back.num_scale_pairs, 64);
  EXPECT_EQ(back.rmse_px, 0.71);
}

TEST(SlamMessages, MalformedLoopConstraintsAreRefused) {
  const scale_drift_slam::Sim3Constraint msg = toSim3ConstraintMsg(someConstraint());
  for (const double scale : {0.0, -1.0, std::numeric_limits<double>::quiet_NaN(),
                             std::numeric_limits<double>::infinity()}) {
    scale_drift_slam::Sim3Constraint bad = msg;
    bad.measurement.scale = scale;
    EXPECT_THROW(fromSim3ConstraintMsg(bad), std::invalid_argument) << scale;
  }
  scale_drift_slam::Sim3Constraint nan_translation = msg;
  nan_translation.measurement.translation.y = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(fromSim3ConstraintMsg(nan_translation), std::invalid_argument);
  scale_drift_slam::Sim3Constraint zero_rotation = msg;
  zero_rotation.measurement.rotation = geometry_msgs::Quaternion();
  zero_rotation.measurement.rotation.w = 0.0;
  EXPECT_THROW(fromSim3ConstraintMsg(zero_rotation), std::invalid_argument);
  scale_drift_slam::Sim3Constraint same = msg;
  same.to_keyframe_id = same.from_keyframe_id;
  EXPECT_THROW(fromSim3ConstraintMsg(same), std::invalid_argument);
  scale_drift_slam::Sim3Constraint huge = msg;
  huge.to_keyframe_id = 1ull << 40;
  EXPECT_THROW(fromSim3ConstraintMsg(huge), std::invalid_argument);
}

TEST(SlamMessages, RelocalisationRoundTrip) {
  map::RelocalisationRequest request;
  request.frame_index = 4711;
  request.timestamp = 1016.5;
  request.map_version = 88;
  request.image = cv::Mat(24, 32, CV_8UC1);
  cv::randu(request.image, 0, 255);
  const scale_drift_slam::RelocalisationRequest request_msg = toRelocalisationRequestMsg(request);
  EXPECT_EQ(request_msg.image.encoding, "mono8");
  const map::RelocalisationRequest request_back = fromRelocalisationRequestMsg(request_msg);
  EXPECT_EQ(request_back.frame_index, 4711u);
  EXPECT_EQ(request_back.timestamp, 1016.5);
  EXPECT_EQ(request_back.map_version, 88u);
  EXPECT_EQ(cv::norm(request_back.image, request.image, cv::NORM_INF), 0.0);
  scale_drift_slam::RelocalisationRequest no_image = request_msg;
  no_image.image = sensor_msgs::Image();
  EXPECT_THROW(fromRelocalisationRequestMsg(no_image), std::invalid_argument);
  scale_drift_slam::RelocalisationRequest colour = request_msg;
  colour.image.encoding = "rgb8";
  EXPECT_THROW(fromRelocalisationRequestMsg(colour), std::invalid_argument);

  map::RelocalisationAnswer answer;
  answer.frame_index = 4711;
  answer.timestamp = 1016.5;
  answer.success = true;
  answer.keyframe_id = 31;
  answer.T_cam_world = somePose(2.0);
  answer.map_version = 87;
  answer.inliers = 2;
  answer.points = {{5, {100.5, 200.25}, {-0.1, 0.2}}, {9, {10.0, 20.0}, {0.3, -0.4}}};
  const scale_drift_slam::RelocalisationAnswer answer_msg = toRelocalisationAnswerMsg(answer);
  const map::RelocalisationAnswer back = fromRelocalisationAnswerMsg(answer_msg);
  EXPECT_EQ(back.frame_index, 4711u);
  EXPECT_EQ(back.timestamp, 1016.5);
  EXPECT_TRUE(back.success);
  EXPECT_EQ(back.reason, "");
  EXPECT_EQ(back.keyframe_id, 31u);
  EXPECT_LT((back.T_cam_world.matrix() - answer.T_cam_world.matrix()).norm(), 1e-15);
  EXPECT_EQ(back.map_version, 87u);
  EXPECT_EQ(back.inliers, 2);
  ASSERT_EQ(back.points.size(), 2u);
  EXPECT_EQ(back.points[1].id, 9u);
  EXPECT_EQ(back.points[0].px, answer.points[0].px);
  EXPECT_EQ(back.points[1].xy, answer.points[1].xy);

  scale_drift_slam::RelocalisationAnswer nan_pose = answer_msg;
  nan_pose.T_cam_world.position.x = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(fromRelocalisationAnswerMsg(nan_pose), std::invalid_argument);
  nan_pose.success = false;  // a failed answer's pose is not read
  nan_pose.reason = "no keyframe looks like this frame";
  nan_pose.points.clear();
  EXPECT_EQ(fromRelocalisationAnswerMsg(nan_pose).reason, "no keyframe looks like this frame");
  scale_drift_slam::RelocalisationAnswer nan_point = answer_msg;
  nan_point.points[0].x = std::numeric_limits<double>::infinity();
  EXPECT_THROW(fromRelocalisationAnswerMsg(nan_point), std::invalid_argument);
}

TEST(SlamMessages, TrackingStatusCarriesTheVerdict) {
  tracking::FrameResult r;
  r.state = tracking::TrackingState::kWeak;
  r.has_pose = true;
  r.num_visible = 200;
  r.num_found = 120;
  r.num_inliers = 30;
  r.times.flow = 2.5;
  r.times.total = 7.0;
  r.message = "weak";
  scale_drift_slam::TrackingStatus s = toTrackingStatusMsg(r);
  EXPECT_EQ(s.state, scale_drift_slam::TrackingStatus::WEAK);
  EXPECT_EQ(s.state_name, "weak");
  EXPECT_TRUE(s.has_pose);
  EXPECT_FALSE(s.rejected);
  EXPECT_EQ(s.visible, 200u);
  EXPECT_EQ(s.matches, 120u);
  EXPECT_EQ(s.inliers, 30u);
  EXPECT_FLOAT_EQ(s.flow_ms, 2.5f);
  EXPECT_FLOAT_EQ(s.total_ms, 7.0f);
  EXPECT_EQ(s.message, "weak");
  r.state = tracking::TrackingState::kLost;
  EXPECT_EQ(toTrackingStatusMsg(r).state, scale_drift_slam::TrackingStatus::LOST);
  r.state = tracking::TrackingState::kInitializing;
  EXPECT_EQ(toTrackingStatusMsg(r).state, scale_drift_slam::TrackingStatus::INITIALIZING);
  r.state = tracking::TrackingState::kGood;
  EXPECT_EQ(toTrackingStatusMsg(r).state, scale_drift_slam::TrackingStatus::GOOD);
}

}  // namespace
}  // namespace scale_drift_slam::ros_conversions
