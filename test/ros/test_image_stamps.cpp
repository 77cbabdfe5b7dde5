// The tracking node's image stamp check: the first image and later stamps are tracked, the
// previous image's stamp is a duplicate, an earlier stamp (a bag played again) resets the tracker.

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

TEST(ImageStamps, AnEarlierStampRestartsTheTracker) {
  const ImageStampCheck check = checkImageStamp(ros::Time(5.0), ros::Time(1.0));
  EXPECT_FALSE(check.duplicate);
  EXPECT_NE(check.restart_reason.find("jumped backwards from 5.000000 to 1.000000 s"),
            std::string::npos)
      << check.restart_reason;
}

}  // namespace
}  // namespace scale_drift_slam::ros_conversions
