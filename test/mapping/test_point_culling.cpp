// Weak-point culling on small hand-made maps whose answer is known: with fewer than 3 observing
// keyframes and 3 keyframes after the last observation, only the points last seen in the
// keyframe 3 before the newest, seen by at most 2 keyframes and behind the newest keyframe go,
// each exactly once over the keyframes that follow; the Mapper removes them from its map and
// names them in its update.

#include <gtest/gtest.h>

#include <algorithm>
#include <set>

#include "scale_drift_slam/mapping/mapper.h"
#include "scale_drift_slam/mapping/point_culling.h"

namespace scale_drift_slam::mapping {
namespace {

/// Keyframe `id` with its camera at z = id, looking along +z (a camera driving forward).
map::Keyframe keyframe(map::KeyframeId id) {
  map::Keyframe k;
  k.id = id;
  k.timestamp = id;
  k.T_kf_world =
      geometry::SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.0, 0.0, -1.0 * id));
  return k;
}

/// Keyframes 0..n-1; point p is observed by the keyframes listed for it and lies at z = 2 (behind
/// keyframes 2 and later) or, if listed in `ahead`, at z = 100.
map::Map makeMap(int n, const std::vector<std::vector<map::KeyframeId>>& observers,
                 const std::vector<map::PointId>& ahead = {}) {
  map::Map map;
  for (int k = 0; k < n; ++k)
    map.addKeyframe(keyframe(static_cast<map::KeyframeId>(k)));
  for (std::size_t p = 0; p < observers.size(); ++p) {
    const auto id = static_cast<map::PointId>(p);
    const bool in_front = std::find(ahead.begin(), ahead.end(), id) != ahead.end();
    map.addPoint({id, Eigen::Vector3d(0.0, 0.0, in_front ? 100.0 : 2.0), observers[p].front(), {}});
    for (const map::KeyframeId k : observers[p])
      map.addObservation(k, id, Eigen::Vector2d::Zero());
  }
  return map;
}

TEST(PointCulling, CullsPointsSeenTwiceOnceThreeKeyframesPassed) {
  // Keyframes 0..6: the aged keyframe is 6 - 3 = 3.
  const map::Map map = makeMap(7, {
                                      {2, 3},     // 0: two views, last in 3: culled
                                      {1, 2, 3},  // 1: three views: kept
                                      {3},        // 2: one view, last in 3: culled
                                      {3, 4},     // 3: last seen in 4: not yet
                                      {1, 2},     // 4: last seen in 2: its turn has passed
                                      {5, 6},     // 5: young
                                  });
  PointCullingParams defaults;
  EXPECT_EQ(defaults.after_keyframes, 10);  // the window BA's size
  defaults.after_keyframes = 3;
  EXPECT_EQ(weakPoints(map, defaults), (std::vector<map::PointId>{0, 2}));
  // The same, with point 2 still ahead of the newest keyframe: kept (it may be found again).
  const map::Map ahead = makeMap(7, {{2, 3}, {1, 2, 3}, {3}, {3, 4}, {1, 2}, {5, 6}}, {2});
  EXPECT_EQ(weakPoints(ahead, defaults), (std::vector<map::PointId>{0}));
  PointCullingParams two = defaults;
  two.min_keyframes = 2;
  EXPECT_EQ(weakPoints(map, two), (std::vector<map::PointId>{2}));
  PointCullingParams off = defaults;
  off.min_keyframes = 0;
  EXPECT_TRUE(weakPoints(map, off).empty());
  PointCullingParams later = defaults;
  later.after_keyframes = 2;  // aged keyframe 4
  EXPECT_EQ(weakPoints(map, later), (std::vector<map::PointId>{3}));
  // Too few keyframes to have an aged one.
  EXPECT_TRUE(weakPoints(makeMap(3, {{0}}), defaults).empty());
  PointCullingParams bad = defaults;
  bad.after_keyframes = 0;
  EXPECT_THROW(weakPoints(map, bad), std::invalid_argument);
}

TEST(PointCulling, TheMapperCullsEachWeakPointOnceAsKeyframesCome) {
  MapperParams params;
  params.run_window_ba = false;  // the culling, not the BA, is under test
  params.point_culling.after_keyframes = 3;
  Mapper mapper(params, 500.0);
  // Keyframe k (camera at z = k) promotes point k + 1 at z = k + 0.5 (seen by k-1 and k), and
  // re-observes point 0 (seen by all).
  std::set<map::PointId> removed;
  for (map::KeyframeId k = 0; k < 10; ++k) {
    map::KeyframeMessage message;
    message.keyframe = keyframe(k);
    message.new_points.push_back({k + 1, Eigen::Vector3d(0.0, 0.0, k + 0.5), k});
    if (k == 0) message.new_points.push_back({0, Eigen::Vector3d(1.0, 0.0, 5.0), 0});
    message.keyframe.observations.push_back({0, Eigen::Vector2d::Zero()});
    message.keyframe.observations.push_back({k + 1, Eigen::Vector2d::Zero()});
    if (k > 0) message.earlier_observations.push_back({k - 1, k + 1, Eigen::Vector2d::Zero()});
    const map::MapUpdate update = mapper.addKeyframe(message);
    for (const map::PointId id : update.removed_points) {
      EXPECT_TRUE(removed.insert(id).second) << "point " << id << " removed twice";
      EXPECT_FALSE(mapper.map().hasPoint(id));
    }
  }
  // Points 1..7 were last seen in keyframes 0..6 (each by 2 keyframes at most), 3 or more
  // keyframes before the newest (9), and are gone; points 8..10 are young, point 0 is seen by
  // every keyframe.
  EXPECT_EQ(removed, (std::set<map::PointId>{1, 2, 3, 4, 5, 6, 7}));
  EXPECT_EQ(mapper.culledPoints(), 7u);
  EXPECT_TRUE(mapper.map().hasPoint(0));
  EXPECT_EQ(mapper.map().numPoints(), 4u);
}

}  // namespace
}  // namespace scale_drift_slam::mapping
