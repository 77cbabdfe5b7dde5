// The map's bookkeeping: observations are linked both ways, ids are unique, and unknown ids are
// refused with a reason instead of corrupting the map.

#include <gtest/gtest.h>

#include "scale_drift_slam/map/map.h"

namespace scale_drift_slam::map {
namespace {

TEST(Map, LinksObservationsBothWays) {
  Map m;
  m.addPoint({7, Eigen::Vector3d(1, 2, 3), 0, {}});
  m.addPoint({8, Eigen::Vector3d(-1, 0, 5), 0, {}});
  Keyframe kf;
  kf.id = 0;
  kf.observations = {{7, Eigen::Vector2d(0.1, 0.2)}};
  m.addKeyframe(kf);
  m.addObservation(0, 8, Eigen::Vector2d(-0.2, 0.0));
  EXPECT_EQ(m.numObservations(), 2u);
  EXPECT_EQ(m.keyframe(0).observations.size(), 2u);
  EXPECT_EQ(m.point(8).observed_by, std::vector<KeyframeId>{0});
  const auto version = m.version();
  m.bumpVersion();
  EXPECT_EQ(m.version(), version + 1);
}

TEST(Map, ClearingAKeyframesObservationsKeepsItsPose) {
  Map map;
  map.addPoint({1, Eigen::Vector3d(0, 0, 4), 0, {}});
  map.addPoint({2, Eigen::Vector3d(1, 0, 4), 0, {}});
  Keyframe a;
  a.id = 0;
  a.observations = {{1, Eigen::Vector2d::Zero()}, {2, Eigen::Vector2d::Zero()}};
  map.addKeyframe(a);
  Keyframe b;
  b.id = 1;
  b.T_kf_world = geometry::SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-1, 0, 0));
  b.observations = {{2, Eigen::Vector2d::Zero()}};
  map.addKeyframe(b);
  EXPECT_EQ(map.clearObservations(1), (std::vector<PointId>{2}));
  EXPECT_TRUE(map.keyframe(1).observations.empty());
  EXPECT_EQ(map.keyframe(1).T_kf_world.translation(), Eigen::Vector3d(-1, 0, 0));
  EXPECT_EQ(map.point(2).observed_by, (std::vector<KeyframeId>{0}));
  EXPECT_EQ(map.numObservations(), 2u);
  EXPECT_TRUE(map.clearObservations(7).empty());  // unknown: ignored
}

TEST(Map, RefusesBadIds) {
  Map m;
  m.addPoint({1, Eigen::Vector3d(0, 0, 1), 0, {}});
  EXPECT_THROW(m.addPoint({1, Eigen::Vector3d(0, 0, 2), 0, {}}), std::invalid_argument);
  EXPECT_THROW(m.addPoint({2, Eigen::Vector3d(0, NAN, 2), 0, {}}), std::invalid_argument);
  Keyframe kf;
  kf.id = 3;
  kf.observations = {{99, Eigen::Vector2d(0, 0)}};
  EXPECT_THROW(m.addKeyframe(kf), std::invalid_argument);
  EXPECT_EQ(m.numKeyframes(), 0u);
  EXPECT_THROW(m.addObservation(3, 1, Eigen::Vector2d(0, 0)), std::invalid_argument);
  EXPECT_THROW(m.keyframe(3), std::out_of_range);
  EXPECT_THROW(m.point(42), std::out_of_range);
}

}  // namespace
}  // namespace scale_drift_slam::map
