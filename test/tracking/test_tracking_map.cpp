// The tracker's map copy: map updates move known keyframes and points, drop removed points,
// ignore stale versions, and a Sim(3) loop correction moves keyframes and points together (a
// point's projection into a keyframe does not change); local points come from the newest and
// the nearest keyframes, each once; keyframes the tracker made after the newest one an update
// moves ride with that one.

#include <algorithm>

#include <gtest/gtest.h>

#include "scale_drift_slam/geometry/so3.h"
#include "scale_drift_slam/tracking/tracking_map.h"

namespace scale_drift_slam::tracking {
namespace {

TrackingMap smallMap() {
  TrackingMap map;
  for (map::KeyframeId id = 0; id < 4; ++id) {
    // Keyframes 1 m apart along x, looking along z.
    map.addKeyframe(
        {id,
         0.1 * id,
         geometry::SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-1.0 * id, 0, 0)),
         {},
         2 * id});  // its points: 2 id and 2 id + 1
  }
  for (map::PointId id = 0; id < 8; ++id) {
    TrackedPoint point;
    point.id = id;
    point.p_world = Eigen::Vector3d(0.5 * id, 0.1 * id, 4.0);
    point.reference_keyframe = id / 2;
    map.addPoint(std::move(point));
    map.linkPoint(id / 2, id);
  }
  return map;
}

TEST(TrackingMap, AppliesUpdatesByVersion) {
  TrackingMap map = smallMap();
  map::MapUpdate update;
  update.map_version = 5;
  const geometry::SE3 moved(geometry::expSO3(Eigen::Vector3d(0, 0.1, 0)), Eigen::Vector3d(1, 2, 3));
  update.keyframe_poses = {{2, moved}, {99, moved}};
  update.point_positions = {{3, Eigen::Vector3d(7, 8, 9)}, {77, Eigen::Vector3d::Zero()}};
  update.removed_points = {4};
  EXPECT_TRUE(map.apply(update));
  EXPECT_LT((map.keyframe(2).T_kf_world.translation() - moved.translation()).norm(), 1e-12);
  EXPECT_EQ(map.point(3).p_world, Eigen::Vector3d(7, 8, 9));
  EXPECT_FALSE(map.hasPoint(4));
  EXPECT_FALSE(map.hasKeyframe(99));
  map::MapUpdate stale;
  stale.map_version = 4;
  stale.point_positions = {{3, Eigen::Vector3d::Zero()}};
  EXPECT_FALSE(map.apply(stale));
  EXPECT_EQ(map.point(3).p_world, Eigen::Vector3d(7, 8, 9));
}

TEST(TrackingMap, Sim3CorrectionKeepsProjections) {
  TrackingMap map = smallMap();
  const Eigen::Vector2d before = (map.keyframe(1).T_kf_world * map.point(2).p_world).hnormalized();
  map::MapUpdate update;
  update.map_version = 1;
  update.S_new_old = geometry::Sim3(geometry::expSO3(Eigen::Vector3d(0.2, -0.1, 0.3)),
                                    Eigen::Vector3d(1, -2, 0.5), std::log(1.7));
  map.apply(update);
  const Eigen::Vector3d p_kf = map.keyframe(1).T_kf_world * map.point(2).p_world;
  EXPECT_LT((p_kf.hnormalized() - before).norm(), 1e-12);
  // The camera centre moves with the similarity.
  EXPECT_LT((map.keyframe(1).T_kf_world.inverseTranslation() -
             *update.S_new_old * Eigen::Vector3d(1, 0, 0))
                .norm(),
            1e-12);
}

// The mapper's bundle adjustment moved keyframes 1-2 and points 2-5 (all by one rigid motion C,
// point 5 also on its own) while the tracker had already made keyframe 3 with points 6-7: those
// ride with keyframe 2, by C; keyframe 0 and its points, which the update leaves, stay.
TEST(TrackingMap, KeyframesNewerThanAnUpdateRideWithItsNewestKeyframe) {
  TrackingMap map = smallMap();
  const geometry::SE3 C(geometry::expSO3(Eigen::Vector3d(0.02, 0.1, -0.05)),
                        Eigen::Vector3d(0.3, -0.2, 0.5));
  map::MapUpdate update;
  update.map_version = 1;
  for (map::KeyframeId id : {1u, 2u})
    update.keyframe_poses.emplace_back(id, map.keyframe(id).T_kf_world * C.inverse());
  for (map::PointId id = 2; id < 6; ++id)
    update.point_positions.emplace_back(id, C * map.point(id).p_world);
  update.point_positions.back().second += Eigen::Vector3d(0, 0, 0.1);
  const TrackingMap before = map;

  const std::optional<TrackingMap::TailCorrection> tail = map.tailCorrection(update);
  ASSERT_TRUE(tail);
  EXPECT_EQ(tail->anchor, 2u);
  ASSERT_TRUE(map.apply(update));
  map.moveTail(*tail);

  const auto expectPose = [&](map::KeyframeId id, const geometry::SE3& expected) {
    const geometry::SE3& T = map.keyframe(id).T_kf_world;
    EXPECT_LT((T.translation() - expected.translation()).norm(), 1e-12) << "keyframe " << id;
    EXPECT_LT(T.rotation().angularDistance(expected.rotation()), 1e-12) << "keyframe " << id;
  };
  expectPose(0, before.keyframe(0).T_kf_world);
  expectPose(3, before.keyframe(3).T_kf_world * C.inverse());
  for (map::PointId id : {6u, 7u})
    EXPECT_LT((map.point(id).p_world - C * before.point(id).p_world).norm(), 1e-12) << id;
  for (map::PointId id : {0u, 1u})
    EXPECT_EQ(map.point(id).p_world, before.point(id).p_world);
  EXPECT_EQ(map.point(5).p_world, update.point_positions.back().second);
  // Keyframe 3 sees its points where it saw them before.
  const Eigen::Vector3d seen = map.keyframe(3).T_kf_world * map.point(6).p_world;
  EXPECT_LT((seen - before.keyframe(3).T_kf_world * before.point(6).p_world).norm(), 1e-12);

  // No tail: an update of the newest keyframe, or a loop correction (which moves everything).
  map::MapUpdate newest;
  newest.map_version = 2;
  newest.keyframe_poses.emplace_back(3, map.keyframe(3).T_kf_world);
  EXPECT_FALSE(map.tailCorrection(newest));
  update.map_version = 2;
  update.S_new_old = geometry::Sim3();
  EXPECT_FALSE(map.tailCorrection(update));
}

TEST(TrackingMap, ACulledKeyframeKeepsItsPoseButGivesNoPoints) {
  TrackingMap map = smallMap();
  map.linkPoint(1, 0);  // point 0: keyframes 0 and 1
  map::MapUpdate update;
  update.map_version = 1;
  update.culled_keyframes = {0};
  ASSERT_TRUE(map.apply(update));
  ASSERT_TRUE(map.hasKeyframe(0));  // the pose stays (keyframe rule, patch references)
  EXPECT_TRUE(map.keyframe(0).points.empty());
  EXPECT_EQ(map.keyframeCentres().size(), 4u);
  EXPECT_TRUE(map.hasPoint(1));  // its points stay, now reached through other keyframes only
  // Nearest to x = 0.1 is keyframe 0, but it holds no points: keyframe 1 is taken instead.
  std::vector<map::PointId> ids = map.localPoints(Eigen::Vector3d(0.1, 0, 0), 1, 1, {0}, 1, 1);
  std::sort(ids.begin(), ids.end());
  EXPECT_EQ(ids, (std::vector<map::PointId>{0, 2, 3, 6, 7}));
  // Keyframe 0 no longer shares point 0 with keyframe 1.
  EXPECT_EQ(map.neighbourhood({1}, 1, 1).count(0), 0u);
}

TEST(TrackingMap, RemovedPointsLeaveTheKeyframesAndTheirSharing) {
  TrackingMap map = smallMap();
  map.linkPoint(1, 0);
  EXPECT_EQ(map.neighbourhood({1}, 1, 1).count(0), 1u);
  map::MapUpdate update;
  update.map_version = 1;
  update.removed_points = {0};
  ASSERT_TRUE(map.apply(update));
  EXPECT_EQ(map.keyframe(0).points, (std::vector<map::PointId>{1}));
  EXPECT_EQ(map.neighbourhood({1}, 1, 1).count(0), 0u);
}

TEST(TrackingMap, LocalPointsFromNewestAndNearestKeyframes) {
  TrackingMap map = smallMap();
  map.linkPoint(3, 0);  // point 0 is also seen by keyframe 3: it must come once
  // Newest keyframe (3) and the one nearest to x = 0.1 (keyframe 0).
  std::vector<map::PointId> ids = map.localPoints(Eigen::Vector3d(0.1, 0, 0), 1, 1, {}, 1, 1);
  std::sort(ids.begin(), ids.end());
  EXPECT_EQ(ids, (std::vector<map::PointId>{0, 1, 6, 7}));
  EXPECT_EQ(map.keyframeCentres().size(), 4u);
}

TEST(TrackingMap, IdlePointsPatchesAreCompressedAndExpandedWhenSelectedAgain) {
  TrackingMap map = smallMap();
  cv::Mat level0(21, 21, CV_8UC1), level1(21, 21, CV_8UC1);
  cv::randu(level0, 0, 255);
  cv::randu(level1, 0, 255);
  for (map::PointId id = 0; id < 8; ++id) {
    map.point(id).appearance.setPatches(level0, level1);
    map.point(id).last_selected_frame = id < 4 ? 10 : 95;  // points 4-7 searched recently
  }
  // Frame 100, idle after 50 frames: points 0-3 (last searched at frame 10) are compressed.
  EXPECT_EQ(map.compressIdlePatches(100, 50), 4u);
  for (map::PointId id = 0; id < 8; ++id)
    EXPECT_EQ(map.point(id).appearance.compressed(), id < 4) << id;
  EXPECT_EQ(map.compressIdlePatches(100, 50), 0u);  // nothing new
  // Keyframe 0 (points 0 and 1; point 1 tracked in the last frame brings it into the tracked
  // region) selected again: their patches are 8 bits again.
  map.localPoints(Eigen::Vector3d(0.1, 0, 0), 1, 1, {1}, 1, 101);
  EXPECT_FALSE(map.point(0).appearance.compressed());
  EXPECT_FALSE(map.point(1).appearance.compressed());
  EXPECT_TRUE(map.point(2).appearance.compressed());
  EXPECT_LE(cv::norm(map.point(0).appearance.patch(0), level0, cv::NORM_INF), 255.0 / 30 + 0.5);
}

TEST(TrackingMap, NearestKeyframesComeOnlyFromTheCovisibleNeighbourhood) {
  TrackingMap map = smallMap();  // no keyframes share points: none is linked to the newest (3)
  std::vector<map::PointId> ids = map.localPoints(Eigen::Vector3d(0.1, 0, 0), 1, 1, {}, 1, 1);
  std::sort(ids.begin(), ids.end());
  EXPECT_EQ(ids, (std::vector<map::PointId>{6, 7}));  // keyframe 0 is near but unrelated
  // A point tracked in the previous frame brings its keyframe into the tracked region.
  ids = map.localPoints(Eigen::Vector3d(0.1, 0, 0), 1, 1, {1}, 1, 2);
  std::sort(ids.begin(), ids.end());
  EXPECT_EQ(ids, (std::vector<map::PointId>{0, 1, 6, 7}));
  // A loop link joins keyframe 1 to the newest.
  map.linkKeyframes(3, 1);
  ids = map.localPoints(Eigen::Vector3d(1.1, 0, 0), 1, 1, {}, 1, 3);
  std::sort(ids.begin(), ids.end());
  EXPECT_EQ(ids, (std::vector<map::PointId>{2, 3, 6, 7}));
  // Two keyframes sharing fewer points than min_shared are not neighbours.
  map.linkPoint(3, 0);
  EXPECT_EQ(map.neighbourhood({3}, 1, 2).count(0), 0u);
  EXPECT_EQ(map.neighbourhood({3}, 1, 1).count(0), 1u);
}

}  // namespace
}  // namespace scale_drift_slam::tracking
