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
