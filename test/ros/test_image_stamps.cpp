// The tracking node's image stamp check: the first image and later stamps are tracked, the
// previous image's stamp is a duplicate, a stamp 1 ms earlier (a driver glitch) is dropped
// without losing the map, a jump back beyond the threshold (a bag played again) resets the
// tracker.

#include <gtest/gtest.h>

#include "scale_drift_slam/ros/image_stamps.h"

namespace scale_drift_slam::ros_conversions {
namespace {

TEST(ImageStamps, FirstAndLaterImagesAreTracked) {
  for (const auto& [last, stamp] :
       {std::pair{ros::Time(), ros::Time(5.0)}, std::pair{ros::Time(5.0), ros::Time(5.01)}}) {
    const ImageStampCheck check = checkImageStamp(last, stamp);
    EXPECT_FALSE(check.duplicate);
    EXPECT_TRUE(check.restart_reason.empty());
  }
}

TEST(ImageStamps, TheSameStampIsADuplicate) {
  const ImageStampCheck check = checkImageStamp(ros::Time(5.0), ros::Time(5.0));
  EXPECT_TRUE(check.duplicate);
  EXPECT_TRUE(check.restart_reason.empty());
}

TEST(ImageStamps, ASmallStepBackIsDroppedNotARestart) {
  const ImageStampCheck check = checkImageStamp(ros::Time(5.0), ros::Time(4.999));
  EXPECT_FALSE(check.duplicate);
  EXPECT_TRUE(check.restart_reason.empty()) << check.restart_reason;
  EXPECT_NE(check.drop_reason.find("driver glitch"), std::string::npos) << check.drop_reason;
  // Up to the threshold, given by the node parameter ~time_jump_restart_s.
  EXPECT_TRUE(checkImageStamp(ros::Time(5.0), ros::Time(4.0), 1.0).restart_reason.empty());
  EXPECT_FALSE(checkImageStamp(ros::Time(5.0), ros::Time(4.0), 0.5).restart_reason.empty());
}

TEST(ImageStamps, AnEarlierStampRestartsTheTracker) {
  const ImageStampCheck check = checkImageStamp(ros::Time(5.0), ros::Time(1.0));
  EXPECT_FALSE(check.duplicate);
  EXPECT_NE(check.restart_reason.find("jumped backwards from 5.000000 to 1.000000 s"),
            std::string::npos)
      << check.restart_reason;
}

}  // namespace
}  // namespace scale_drift_slam::ros_conversions
