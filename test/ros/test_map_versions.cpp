// Map versions across mapping-node restarts: the first mapper's versions pass unchanged, a new
// mapper continues above the tracker's version, updates of retired mappers are dropped, and
// keyframes report versions in the current mapper's numbering.

#include <gtest/gtest.h>

#include "scale_drift_slam/ros/map_versions.h"

namespace scale_drift_slam::ros_conversions {
namespace {

TEST(MapVersions, FirstMapperPassesUnchanged) {
  MapVersionTranslator t;
  EXPECT_EQ(t.toMapper(0), 0u);
  bool new_mapper = false;
  EXPECT_EQ(t.toTracker(7, 300, 0, &new_mapper), 300u);
  EXPECT_TRUE(new_mapper);
  EXPECT_EQ(t.toTracker(7, 450, 300, &new_mapper), 450u);
  EXPECT_FALSE(new_mapper);
  EXPECT_EQ(t.toMapper(450), 450u);
  EXPECT_EQ(t.toTracker(7, 200, 450), std::nullopt);  // older than the mapper's first
}

TEST(MapVersions, RestartedMapperContinuesAboveTheTracker) {
  MapVersionTranslator t;
  t.toTracker(7, 300, 0);
  t.toTracker(7, 5000, 300);  // the tracker is at 5000
  EXPECT_EQ(t.toMapper(5000), 5000u);
  // Mapper 9 starts from an empty map: its versions are small.
  bool new_mapper = false;
  EXPECT_EQ(t.toTracker(9, 40, 5000, &new_mapper), 5001u);
  EXPECT_TRUE(new_mapper);
  EXPECT_EQ(t.toTracker(9, 90, 5001), 5051u);
  // Keyframes report versions the new mapper knows; 0 before any of its updates was applied.
  EXPECT_EQ(t.toMapper(5051), 90u);
  EXPECT_EQ(t.toMapper(4999), 0u);
  // A late update of the old mapper does not switch back.
  EXPECT_EQ(t.toTracker(7, 5100, 5051), std::nullopt);
  t.reset();
  EXPECT_EQ(t.toMapper(5051), 0u);
  EXPECT_EQ(t.toTracker(7, 12, 0), 12u);  // after a reset every mapper is welcome again
}

}  // namespace
}  // namespace scale_drift_slam::ros_conversions
