// Keyframe culling on hand-made maps whose answer is known: the keyframe that just left the
// window is culled when at least 90 % of its points are seen by 2 other keyframes, never the
// oldest or a loop edge's end; the Mapper clears its observations (its pose stays), drops the
// points it leaves unobserved and names both in its update.

#include <gtest/gtest.h>

#include "scale_drift_slam/mapping/keyframe_culling.h"
#include "scale_drift_slam/mapping/mapper.h"

namespace scale_drift_slam::mapping {
namespace {

/// Keyframes 0..5; keyframe 3 sees points 0..9; points 0..`covered`-1 are also seen by
/// keyframes 0, 1 and 2, the others only by keyframe 4.
map::Map makeMap(int covered) {
  map::Map map;
  for (map::PointId p = 0; p < 10; ++p)
    map.addPoint({p, Eigen::Vector3d(0.1 * p, 0.0, 5.0), 3, {}});
  for (map::KeyframeId k = 0; k < 6; ++k) {
    map::Keyframe keyframe;
    keyframe.id = k;
    for (map::PointId p = 0; p < 10; ++p) {
      const bool sees = k == 3 || (static_cast<int>(p) < covered ? k < 3 : k == 4);
      if (sees) keyframe.observations.push_back({p, Eigen::Vector2d::Zero()});
    }
    map.addKeyframe(keyframe);
  }
  return map;
}

TEST(KeyframeCulling, CullsTheKeyframeLeavingTheWindowWhenItsPointsAreCovered) {
  const KeyframeCullingParams defaults;
  // Window of 2: keyframe 3 has just left it (keyframes 4 and 5 are newer).
  EXPECT_EQ(redundantKeyframe(makeMap(9), 2, defaults, {}), map::KeyframeId{3});
  EXPECT_FALSE(redundantKeyframe(makeMap(8), 2, defaults, {}).has_value());   // 80 % < 90 %
  EXPECT_FALSE(redundantKeyframe(makeMap(9), 2, defaults, {3}).has_value());  // a loop's end
  EXPECT_FALSE(redundantKeyframe(makeMap(9), 1, defaults, {}).has_value());   // keyframe 4
  KeyframeCullingParams looser = defaults;
  looser.redundant_ratio = 0.8;
  EXPECT_EQ(redundantKeyframe(makeMap(8), 2, looser, {}), map::KeyframeId{3});
  KeyframeCullingParams stricter = defaults;
  stricter.min_other_observers = 4;
  EXPECT_FALSE(redundantKeyframe(makeMap(10), 2, stricter, {}).has_value());
  KeyframeCullingParams off = defaults;
  off.redundant_ratio = 0.0;
  EXPECT_FALSE(redundantKeyframe(makeMap(10), 2, off, {}).has_value());
  // The oldest keyframe anchors the world: never culled (window of 5: keyframe 0).
  EXPECT_FALSE(redundantKeyframe(makeMap(10), 5, defaults, {}).has_value());
  KeyframeCullingParams bad = defaults;
  bad.redundant_ratio = 1.5;
  EXPECT_THROW(redundantKeyframe(makeMap(9), 2, bad, {}), std::invalid_argument);
}

TEST(KeyframeCulling, TheMapperClearsTheCulledKeyframeAndItsOrphanPoints) {
  MapperParams params;
  params.run_window_ba = false;  // the culling, not the BA, is under test
  params.point_culling.min_keyframes = 0;
  params.window.window_size = 10;
  Mapper mapper(params, 500.0);
  // Every keyframe k sees the shared points 0..9 and its own point 100 + k: 10 of its 11 points
  // are seen by 2 other keyframes once there are 3.
  std::vector<map::KeyframeId> culled;
  std::vector<map::PointId> removed;
  for (map::KeyframeId k = 0; k < 15; ++k) {
    map::KeyframeMessage message;
    message.keyframe.id = k;
    message.keyframe.timestamp = k;
    message.keyframe.T_kf_world =
        geometry::SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-0.1 * k, 0.0, 0.0));
    if (k == 0) {
      for (map::PointId p = 0; p < 10; ++p)
        message.new_points.push_back({p, Eigen::Vector3d(0.1 * p, 0.0, 5.0), 0});
    }
    message.new_points.push_back({100 + k, Eigen::Vector3d(0.0, 0.1 * k, 5.0), k});
    for (map::PointId p = 0; p < 10; ++p)
      message.keyframe.observations.push_back({p, Eigen::Vector2d::Zero()});
    message.keyframe.observations.push_back({100 + k, Eigen::Vector2d::Zero()});
    const map::MapUpdate update = mapper.addKeyframe(message);
    culled.insert(culled.end(), update.culled_keyframes.begin(), update.culled_keyframes.end());
    removed.insert(removed.end(), update.removed_points.begin(), update.removed_points.end());
  }
  // Keyframe 0 is the oldest; keyframes 1..4 left the window of 10 as keyframes 11..14 came.
  EXPECT_EQ(culled, (std::vector<map::KeyframeId>{1, 2, 3, 4}));
  EXPECT_EQ(removed, (std::vector<map::PointId>{101, 102, 103, 104}));
  EXPECT_EQ(mapper.culledKeyframes(), 4u);
  ASSERT_TRUE(mapper.map().hasKeyframe(2));
  EXPECT_TRUE(mapper.map().keyframe(2).observations.empty());
  EXPECT_NEAR(mapper.map().keyframe(2).T_kf_world.translation().x(), -0.2, 1e-12);
  EXPECT_EQ(mapper.map().point(5).observed_by.size(), 11u);  // 15 keyframes, 4 culled
  EXPECT_FALSE(mapper.map().hasPoint(102));
  EXPECT_TRUE(mapper.map().hasPoint(100));
}

}  // namespace
}  // namespace scale_drift_slam::mapping
