// Image preparation: every encoding a camera or bag delivers becomes the same grey image, a wrong
// encoding is refused with a reason, and unusable frames (black, blank, wrong size) are named.

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "../tracking/synthetic_images.h"
#include "scale_drift_slam/features/image_preparation.h"

namespace scale_drift_slam::features {
namespace {

TEST(ImagePreparation, AllEncodingsGiveTheSameGrey) {
  const cv::Mat grey = test::texturedImage(64, 48, 1);
  cv::Mat bgr, rgb, bgra, rgba, mono16;
  cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
  cv::cvtColor(grey, rgb, cv::COLOR_GRAY2RGB);
  cv::cvtColor(grey, bgra, cv::COLOR_GRAY2BGRA);
  cv::cvtColor(grey, rgba, cv::COLOR_GRAY2RGBA);
  grey.convertTo(mono16, CV_16U, 256.0);
  const std::pair<cv::Mat, std::string> inputs[] = {{grey, "mono8"}, {bgr, "bgr8"},
                                                    {rgb, "rgb8"},   {bgra, "bgra8"},
                                                    {rgba, "rgba8"}, {mono16, "mono16"}};
  for (const auto& [image, name] : inputs) {
    const cv::Mat out = toGrey(image, parsePixelEncoding(name));
    ASSERT_EQ(out.type(), CV_8UC1) << name;
    EXPECT_EQ(cv::norm(out, grey, cv::NORM_INF), 0.0) << name;
    EXPECT_EQ(pixelEncodingName(parsePixelEncoding(name)), name);
  }
}

// Issue 17: 16-bit PNGs holding 12-bit data were scaled by 1/256, so every frame used 1/16 of
// the grey range and was rejected as "no texture".
TEST(ImagePreparation, SixteenBitImagesAreScaledByTheirBitDepth) {
  const cv::Mat grey = test::texturedImage(64, 48, 1);
  cv::Mat twelve_bit;
  grey.convertTo(twelve_bit, CV_16U, 16.0);  // values 320..3760: 12 bits
  EXPECT_EQ(significantBits(twelve_bit), 12);
  EXPECT_EQ(cv::norm(toGrey(twelve_bit, PixelEncoding::kMono16, 12), grey, cv::NORM_INF), 0.0);
  // Read as 16-bit data the same frame has a sixteenth of its contrast: the old failure.
  cv::Scalar mean, full_std, dim_std;
  cv::meanStdDev(grey, mean, full_std);
  cv::meanStdDev(toGrey(twelve_bit, PixelEncoding::kMono16, 16), mean, dim_std);
  EXPECT_NEAR(dim_std[0], full_std[0] / 16.0, 0.5);
  cv::Mat ten_bit, full;
  grey.convertTo(ten_bit, CV_16U, 4.0);
  grey.convertTo(full, CV_16U, 256.0);
  EXPECT_EQ(significantBits(ten_bit), 10);
  EXPECT_EQ(significantBits(full), 16);
  EXPECT_EQ(significantBits(cv::Mat(4, 4, CV_16UC1, cv::Scalar(3))), 8);  // never below 8
  EXPECT_THROW(significantBits(grey), std::invalid_argument);
  EXPECT_THROW(toGrey(twelve_bit, PixelEncoding::kMono16, 17), std::invalid_argument);
  // Values above the stated depth saturate.
  EXPECT_EQ(toGrey(full, PixelEncoding::kMono16, 12).at<unsigned char>(0, 0), 255);
}

TEST(ImagePreparation, ColourChannelOrderMatters) {
  cv::Mat red(4, 4, CV_8UC3, cv::Scalar(0, 0, 255));  // BGR red
  const cv::Mat as_bgr = toGrey(red, PixelEncoding::kBgr8);
  const cv::Mat as_rgb = toGrey(red, PixelEncoding::kRgb8);
  EXPECT_NEAR(as_bgr.at<unsigned char>(0, 0), 76, 1);  // 0.299 * 255
  EXPECT_NEAR(as_rgb.at<unsigned char>(0, 0), 29, 1);  // 0.114 * 255
}

TEST(ImagePreparation, RefusesWrongEncodingsWithAReason) {
  const cv::Mat bgr(8, 8, CV_8UC3, cv::Scalar(1, 2, 3));
  try {
    toGrey(bgr, PixelEncoding::kMono8);
    ADD_FAILURE() << "accepted a 3-channel image as mono8";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("mono8"), std::string::npos) << e.what();
  }
  EXPECT_THROW(toGrey(cv::Mat(), PixelEncoding::kMono8), std::invalid_argument);
  EXPECT_THROW(toGrey(cv::Mat(4, 4, CV_32FC1), PixelEncoding::kMono16), std::invalid_argument);
  EXPECT_THROW(parsePixelEncoding("yuv422"), std::invalid_argument);
  EXPECT_THROW(encodingOfMat(cv::Mat(4, 4, CV_32FC3)), std::invalid_argument);
  EXPECT_EQ(encodingOfMat(bgr), PixelEncoding::kBgr8);
}

TEST(ImagePreparation, NamesUnusableFrames) {
  EXPECT_EQ(frameProblem(test::texturedImage(64, 48, 2), 64, 48, 2.0), "");
  EXPECT_NE(frameProblem(cv::Mat::zeros(48, 64, CV_8UC1), 64, 48, 2.0).find("texture"),
            std::string::npos);
  EXPECT_NE(frameProblem(cv::Mat(48, 64, CV_8UC1, cv::Scalar(255)), 64, 48, 2.0), "");
  EXPECT_NE(frameProblem(cv::Mat::zeros(3, 2, CV_8UC1), 64, 48, 2.0).find("3"), std::string::npos);
  EXPECT_NE(frameProblem(cv::Mat(), 64, 48, 2.0), "");
}

TEST(ImagePreparation, StretchesADimFrameAndLeavesTheRest) {
  const cv::Mat bright = test::texturedImage(240, 180, 4);
  // The same scene at 1/8 and at 1/10 of the exposure: few grey levels, and a gain change
  // between the two frames.
  cv::Mat dim8, dim10;
  bright.convertTo(dim8, CV_8U, 1.0 / 8.0, 2.0);
  bright.convertTo(dim10, CV_8U, 1.0 / 10.0, 2.0);
  cv::Scalar mean, before, after;
  cv::meanStdDev(dim10, mean, before);
  EXPECT_GT(stretchContrast(&dim8, 128.0, 4.0), 3.9);  // range ~27: capped at 4
  EXPECT_GT(stretchContrast(&dim10, 128.0, 4.0), 3.9);
  cv::meanStdDev(dim10, mean, after);
  EXPECT_NEAR(after[0], 4.0 * before[0], 1.0);
  // Moved up just enough to fit: only the darkest grey levels (the 1st percentile's and below; at
  // ~27 levels in all, each holds a few % of the pixels) end at 0, none at 255.
  EXPECT_LT(cv::countNonZero(dim10 == 0), 0.05 * dim10.total());
  EXPECT_EQ(cv::countNonZero(dim10 == 255), 0);
  // A well-exposed frame is untouched, so are black and uniform ones, which stay rejected.
  cv::Mat copy = bright.clone();
  EXPECT_EQ(stretchContrast(&copy, 128.0, 4.0), 1.0);
  EXPECT_EQ(cv::norm(copy, bright, cv::NORM_INF), 0.0);
  for (const int v : {0, 128, 255}) {
    cv::Mat flat(48, 64, CV_8UC1, cv::Scalar(v));
    EXPECT_EQ(stretchContrast(&flat, 128.0, 4.0), 1.0);
    EXPECT_NE(frameProblem(flat, 64, 48, 3.0).find("texture"), std::string::npos) << v;
  }
  EXPECT_THROW(stretchContrast(&copy, 128.0, 0.5), std::invalid_argument);
  EXPECT_THROW(stretchContrast(&copy, 0.0, 4.0), std::invalid_argument);
}

// A frame whose range is just below the target is hardly changed. When the stretch moved every
// stretched frame's range to mid-grey, such a frame (a wall filling a blurred view in a fast pan:
// grey levels 50-170) was shifted by ~17 levels while its neighbours with a slightly wider range
// were not, and the optical flow lost most of its points on each of those frames.
TEST(ImagePreparation, StretchOfARangeNearTheTargetIsNearlyTheIdentity) {
  cv::Mat frame;
  // The texture's 1st-99th percentile range is ~190 grey levels: ~120 here, centred near 80.
  test::texturedImage(320, 240, 5).convertTo(frame, CV_8U, 0.63, 20.0);
  cv::Mat stretched = frame.clone();
  const double gain = stretchContrast(&stretched, 128.0, 4.0);
  EXPECT_GT(gain, 1.0);
  EXPECT_LT(gain, 1.15);
  cv::Mat difference;
  cv::absdiff(stretched, frame, difference);
  // A pixel moves by (gain - 1) x its distance from the range's centre: at most ~5 grey levels
  // for the frame's darkest and brightest (~80 from the centre), none at the centre. Moved to
  // mid-grey, the pixels would move by ~22 on average.
  double max_difference = 0.0;
  cv::minMaxLoc(difference, nullptr, &max_difference);
  EXPECT_LE(max_difference, (gain - 1.0) * 80.0 + 1.0);
  EXPECT_LE(cv::mean(difference)[0], 2.0);
}

TEST(ImagePreparation, PyramidHalvesEachLevel) {
  const ImagePyramid pyramid = buildPyramid(test::texturedImage(640, 480, 3), 4);
  ASSERT_EQ(pyramid.numLevels(), 4);
  EXPECT_EQ(pyramid.levels[3].cols, 80);
  EXPECT_EQ(pyramid.levels[3].rows, 60);
  // A tiny image stops early instead of producing empty levels.
  EXPECT_EQ(buildPyramid(cv::Mat(100, 100, CV_8UC1, cv::Scalar(5)), 6).numLevels(), 3);
  EXPECT_THROW(buildPyramid(cv::Mat(), 2), std::invalid_argument);
}

// The gradients built with the pyramid are those cv::calcOpticalFlowPyrLK would compute on each
// call: Lucas-Kanade gives the same tracks with them as without, for the plain levels and for
// the photometrically normalised ones.
TEST(ImagePreparation, GradientsBuiltWithThePyramidGiveTheSameFlow) {
  const cv::Mat first = test::texturedImage(320, 240, 7);
  cv::Mat second;
  const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, 3.4, 0, 1, -2.2);
  cv::warpAffine(first, second, shift, first.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT_101);
  std::vector<cv::Point2f> from;
  for (int y = 40; y < 200; y += 20) {
    for (int x = 40; x < 280; x += 20)
      from.emplace_back(static_cast<float>(x), static_cast<float>(y));
  }
  const cv::TermCriteria criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 0.01);
  for (const int photometric_radius : {0, 7}) {
    const ImagePyramid a = buildPyramid(first, 3, 11, photometric_radius);
    const ImagePyramid b = buildPyramid(second, 3, 11, photometric_radius);
    ASSERT_EQ(a.flow_gradients.size(), a.flowLevels().size()) << photometric_radius;
    ASSERT_EQ(a.lucasKanadePyramid(3).size(), 6u);
    std::vector<cv::Point2f> with, without;
    std::vector<unsigned char> ok_with, ok_without;
    std::vector<float> error;
    cv::calcOpticalFlowPyrLK(a.lucasKanadePyramid(3), b.lucasKanadePyramid(3), from, with, ok_with,
                             error, cv::Size(11, 11), 2, criteria);
    cv::calcOpticalFlowPyrLK(a.flowLevels(), b.flowLevels(), from, without, ok_without, error,
                             cv::Size(11, 11), 2, criteria);
    int tracked = 0;
    for (std::size_t i = 0; i < from.size(); ++i) {
      ASSERT_EQ(ok_with[i], ok_without[i]) << photometric_radius << " point " << i;
      EXPECT_NEAR(with[i].x, without[i].x, 1e-4) << photometric_radius << " point " << i;
      EXPECT_NEAR(with[i].y, without[i].y, 1e-4) << photometric_radius << " point " << i;
      if (ok_with[i] && std::abs(with[i].x - from[i].x - 3.4f) < 0.3f &&
          std::abs(with[i].y - from[i].y + 2.2f) < 0.3f) {
        ++tracked;
      }
    }
    // The shift found where there is texture (the grid also falls on flat shapes).
    EXPECT_GT(tracked, static_cast<int>(from.size()) / 2) << photometric_radius;
  }
}

// The base level as a one-level pyramid (the keyframe triangulation's alignment): with its
// gradient the same tracks as from the bare image, which the call pads and differentiates itself;
// not offered when the padding is narrower than the window, and never with the gradient of the
// normalised image, which is not the base's.
TEST(ImagePreparation, TheBaseLevelWithItsGradientGivesTheSameFlowAsTheBareImage) {
  const cv::Mat first = test::texturedImage(320, 240, 9);
  cv::Mat second;
  const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, 1.3, 0, 1, 0.8);
  cv::warpAffine(first, second, shift, first.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT_101);
  std::vector<cv::Point2f> from;
  for (int y = 5; y < 240; y += 17) {  // near the borders too: the padding is read there
    for (int x = 3; x < 320; x += 19)
      from.emplace_back(static_cast<float>(x), static_cast<float>(y));
  }
  const cv::TermCriteria criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 0.01);
  const ImagePyramid a = buildPyramid(first, 3, 11);
  const ImagePyramid b = buildPyramid(second, 3, 11);
  const std::vector<cv::Mat> a_base = a.baseLevelForLucasKanade(11);
  ASSERT_EQ(a_base.size(), 2u);
  EXPECT_EQ(a_base[1].type(), CV_16SC2);
  std::vector<cv::Point2f> with = from, without = from;
  std::vector<unsigned char> ok_with, ok_without;
  std::vector<float> error;
  cv::calcOpticalFlowPyrLK(a_base, b.baseLevelForLucasKanade(11), from, with, ok_with, error,
                           cv::Size(11, 11), 0, criteria, cv::OPTFLOW_USE_INITIAL_FLOW);
  cv::calcOpticalFlowPyrLK(first, second, from, without, ok_without, error, cv::Size(11, 11), 0,
                           criteria, cv::OPTFLOW_USE_INITIAL_FLOW);
  int tracked = 0;
  for (std::size_t i = 0; i < from.size(); ++i) {
    ASSERT_EQ(ok_with[i], ok_without[i]) << "point " << i;
    EXPECT_NEAR(with[i].x, without[i].x, 1e-4) << "point " << i;
    EXPECT_NEAR(with[i].y, without[i].y, 1e-4) << "point " << i;
    tracked += ok_with[i] && std::abs(with[i].x - from[i].x - 1.3f) < 0.2f &&
               std::abs(with[i].y - from[i].y - 0.8f) < 0.2f;
  }
  EXPECT_GT(tracked, static_cast<int>(from.size()) / 2);
  EXPECT_TRUE(a.baseLevelForLucasKanade(13).empty());  // padded by 11 only
  EXPECT_EQ(buildPyramid(first, 3, 11, 7).baseLevelForLucasKanade(11).size(), 1u);
}

}  // namespace
}  // namespace scale_drift_slam::features
