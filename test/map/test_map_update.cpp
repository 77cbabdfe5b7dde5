// Consumers of map updates: a loop correction moves poses and points consistently, messages made
// before a correction are brought into the corrected frame (and only by the corrections after
// them), stale updates are ignored, and the trajectory history moves with its keyframes.

#include <gtest/gtest.h>

#include "scale_drift_slam/geometry/so3.h"
#include "scale_drift_slam/map/corrected_trajectory.h"
#include "scale_drift_slam/map/map_update.h"

namespace scale_drift_slam::map {
namespace {

geometry::Sim3 someSimilarity(double scale) {
  return geometry::Sim3::fromScale(
      Eigen::Quaterniond(geometry::expSO3(Eigen::Vector3d(0.1, -0.3, 0.2))),
      Eigen::Vector3d(1.0, -2.0, 0.5), scale);
}

geometry::SE3 somePose() {
  return geometry::SE3(geometry::expSO3(Eigen::Vector3d(-0.2, 0.4, 0.1)),
                       Eigen::Vector3d(0.3, 0.2, -1.0));
}

TEST(MapUpdate, CorrectedPoseSeesTheCorrectedPointAlongTheSameRayAtScaledDepth) {
  const geometry::Sim3 S = someSimilarity(1.7);
  const geometry::SE3 T = somePose();
  const Eigen::Vector3d p_old(0.5, -0.4, 3.0);
  const Eigen::Vector3d in_camera_old = T * p_old;
  const Eigen::Vector3d in_camera_new = correctPose(T, S) * (S * p_old);
  EXPECT_NEAR((in_camera_new - 1.7 * in_camera_old).norm(), 0.0, 1e-9);
  // The camera centre moves with the world.
  EXPECT_NEAR((correctPose(T, S).inverseTranslation() - S * T.inverseTranslation()).norm(), 0.0,
              1e-9);
}

TEST(MapUpdate, HistoryAppliesOnlyTheCorrectionsAfterTheMessage) {
  CorrectionHistory history;
  MapUpdate window;  // not a loop correction: not recorded
  window.map_version = 5;
  history.record(window);
  MapUpdate first, second;
  first.map_version = 10;
  first.S_new_old = someSimilarity(0.8);
  second.map_version = 20;
  second.S_new_old = someSimilarity(1.3).inverse();
  history.record(first);
  history.record(second);
  ASSERT_EQ(history.size(), 2u);
  EXPECT_FALSE(history.correctionSince(20).has_value());
  const Eigen::Vector3d p(1, 2, 3);
  EXPECT_NEAR((*history.correctionSince(15) * p - *second.S_new_old * p).norm(), 0.0, 1e-9);
  EXPECT_NEAR((*history.correctionSince(4) * p - *second.S_new_old * (*first.S_new_old * p)).norm(),
              0.0, 1e-9);

  KeyframeMessage message;
  message.map_version = 12;
  message.keyframe.T_kf_world = somePose();
  message.new_points.push_back({7, p, 0});
  ASSERT_TRUE(history.bringUpToDate(message));
  EXPECT_NEAR((message.new_points[0].p_world - *second.S_new_old * p).norm(), 0.0, 1e-9);
  EXPECT_EQ(message.map_version, 20u);
  EXPECT_FALSE(history.bringUpToDate(message));  // already current
}

TEST(MapUpdate, ApplyIgnoresStaleUpdatesAndRemovesPoints) {
  Map map;
  map.addPoint({1, Eigen::Vector3d(0, 0, 2), 0, {}});
  map.addPoint({2, Eigen::Vector3d(1, 0, 2), 0, {}});
  map.addKeyframe({0, 0.0, geometry::SE3(), {{1, {0, 0}}, {2, {0.5, 0}}}});
  std::uint64_t version = 0;
  MapUpdate update;
  update.map_version = 3;
  update.S_new_old = someSimilarity(2.0);
  update.point_positions.emplace_back(2, Eigen::Vector3d(5, 5, 5));
  update.removed_points.push_back(1);
  ASSERT_TRUE(applyMapUpdate(update, map, &version));
  EXPECT_EQ(version, 3u);
  EXPECT_FALSE(map.hasPoint(1));
  EXPECT_EQ(map.numObservations(), 1u);
  EXPECT_EQ(map.keyframe(0).observations.size(), 1u);
  EXPECT_EQ(map.point(2).p_world, Eigen::Vector3d(5, 5, 5));  // listed: as given
  EXPECT_NEAR(
      (map.keyframe(0).T_kf_world.inverseTranslation() - update.S_new_old->translation()).norm(),
      0.0, 1e-9);
  MapUpdate stale;
  stale.map_version = 2;
  stale.point_positions.emplace_back(2, Eigen::Vector3d(0, 0, 0));
  EXPECT_FALSE(applyMapUpdate(stale, map, &version));
  EXPECT_EQ(map.point(2).p_world, Eigen::Vector3d(5, 5, 5));
}

TEST(CorrectedTrajectory, FramesMoveWithTheirReferenceKeyframe) {
  CorrectedTrajectory trajectory;
  trajectory.add(1.0, somePose(), 3);
  trajectory.add(2.0, somePose(), 9);  // a keyframe the correction does not list
  trajectory.add(3.0, somePose(), std::nullopt);
  MapUpdate window;
  window.keyframe_poses.emplace_back(3, geometry::SE3());
  trajectory.apply(window);  // no loop correction: nothing moves
  EXPECT_EQ(trajectory.frames()[0].T_cam_world.translation(), somePose().translation());

  MapUpdate loop;
  loop.S_new_old = someSimilarity(0.5);
  loop.keyframe_corrections.emplace_back(3, someSimilarity(2.0));
  trajectory.apply(loop);
  const auto centre = [&](std::size_t i) {
    return trajectory.frames()[i].T_cam_world.inverseTranslation();
  };
  const Eigen::Vector3d c = somePose().inverseTranslation();
  EXPECT_NEAR((centre(0) - someSimilarity(2.0) * c).norm(), 0.0, 1e-9);
  EXPECT_NEAR((centre(1) - someSimilarity(0.5) * c).norm(), 0.0, 1e-9);
  EXPECT_NEAR((centre(2) - someSimilarity(0.5) * c).norm(), 0.0, 1e-9);

  trajectory.keepNewest(5);  // fewer than that: all stay
  EXPECT_EQ(trajectory.size(), 3u);
  trajectory.keepNewest(2);
  ASSERT_EQ(trajectory.size(), 2u);
  EXPECT_EQ(trajectory.frames()[0].timestamp, 2.0);
  EXPECT_EQ(trajectory.frames()[1].timestamp, 3.0);
}

}  // namespace
}  // namespace scale_drift_slam::map
