// Map versions across mapping-node restarts: the first mapper's versions pass unchanged, a new
// mapper continues above the tracker's version, updates of retired mappers are dropped, and
// keyframes report versions in the current mapper's numbering; versions other nodes report in a
// named mapper's numbering come back into the consumer's.

#include <gtest/gtest.h>

#include "scale_drift_slam/system/map_versions.h"

namespace scale_drift_slam::system {
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

TEST(MapVersions, ReportedVersionsOfNamedMappersComeBack) {
  MapVersionTranslator t;
  EXPECT_EQ(t.mapperId(), 0u);
  EXPECT_EQ(t.toConsumer(0, 0), 0u);             // nothing applied by the sender
  EXPECT_EQ(t.toConsumer(7, 12), std::nullopt);  // a mapper not met yet
  t.toTracker(7, 300, 0);
  t.toTracker(7, 5000, 300);
  EXPECT_EQ(t.mapperId(), 7u);
  EXPECT_EQ(t.toConsumer(7, 4000), 4000u);
  EXPECT_EQ(t.toConsumer(7, 100), 100u);  // below the first update met: the same offset
  t.toTracker(9, 40, 5000);               // mapper 9 at 5001
  EXPECT_EQ(t.mapperId(), 9u);
  EXPECT_EQ(t.toConsumer(9, 90), 5051u);
  EXPECT_EQ(t.toConsumer(9, 0), 4961u);
  EXPECT_EQ(t.toConsumer(7, 4500), 4500u);  // the retired mapper keeps its translation
  EXPECT_EQ(t.toConsumer(0, 0), 0u);
  EXPECT_EQ(t.toConsumer(11, 3), std::nullopt);
  MapVersionTranslator offset;  // a second mapper far above its first: clamped at 0 below
  offset.toTracker(3, 10, 0);
  offset.toTracker(5, 1000, 10);  // given as 1000
  EXPECT_EQ(offset.toConsumer(5, 1), 1u);
  MapVersionTranslator late;  // a consumer started late meets the mapper at 1000 -> identity
  late.toTracker(5, 1000, 0);
  EXPECT_EQ(late.toConsumer(5, 2), 2u);
  MapVersionTranslator shifted;
  shifted.toTracker(3, 0, 0);
  shifted.toTracker(4, 0, 5);  // mapper 4's 0 is the consumer's 6
  EXPECT_EQ(shifted.toConsumer(4, 0), 6u);
}

}  // namespace
}  // namespace scale_drift_slam::system
