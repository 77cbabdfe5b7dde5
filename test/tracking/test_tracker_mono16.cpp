// The tracker reads 16-bit frames by their bit depth (issue 17): measured from the largest value
// seen (a 12-bit camera: 12, never lowered by a darker frame), or tracker.mono16_bit_depth.

#include <gtest/gtest.h>

#include "scale_drift_slam/tracking/tracker.h"
#include "synthetic_images.h"

namespace scale_drift_slam::tracking {
namespace {

TEST(TrackerMono16, ReadsTwelveBitFramesWithTheirDepthOrTheConfiguredOne) {
  const cv::Mat grey = test::texturedImage(640, 480, 3);
  cv::Mat twelve_bit, dark;
  grey.convertTo(twelve_bit, CV_16U, 16.0);  // up to 3760: 12 bits
  grey.convertTo(dark, CV_16U, 2.0);         // up to 470: 9 bits
  Tracker measured(test::pinholeCamera(300.0), TrackerParams{});
  EXPECT_EQ(measured.mono16BitDepth(), 0);
  const FrameResult r = measured.processFrame(1.0, twelve_bit, features::PixelEncoding::kMono16);
  EXPECT_FALSE(r.rejected) << r.message;
  EXPECT_EQ(measured.mono16BitDepth(), 12);
  measured.processFrame(1.1, dark, features::PixelEncoding::kMono16);
  EXPECT_EQ(measured.mono16BitDepth(), 12);  // a darker frame does not lower it

  TrackerParams sixteen;
  sixteen.mono16_bit_depth = 16;
  Tracker configured(test::pinholeCamera(300.0), sixteen);
  configured.processFrame(1.0, twelve_bit, features::PixelEncoding::kMono16);
  EXPECT_EQ(configured.mono16BitDepth(), 16);
  sixteen.mono16_bit_depth = 7;
  EXPECT_THROW(sixteen.validate(), std::invalid_argument);
  sixteen.mono16_bit_depth = 0;
  EXPECT_NO_THROW(sixteen.validate());
}

}  // namespace
}  // namespace scale_drift_slam::tracking
