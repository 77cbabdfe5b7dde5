// Camera effects (sim/camera_effects.h) do to the image what they model: vignetting darkens the
// corners by the expected ratio, defocus spreads an edge over the disc only, JPEG changes pixels
// but keeps the mean, a rolling shutter changes a moving camera's rows progressively away from
// the middle row, auto-exposure clips sunlit highlights and follows a brightness step with a lag.

#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "scale_drift_slam/sim/camera_effects.h"
#include "scale_drift_slam/sim/sequence.h"

namespace scale_drift_slam::sim {
namespace {

SequenceParams smallParams(const std::string& scene) {
  SequenceParams params;
  params.scene = scene;
  params.width = 160;
  params.height = 120;
  params.max_frames = 40;
  return params;
}

double meanAbsDifference(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat difference;
  cv::absdiff(a, b, difference);
  return cv::mean(difference)[0];
}

TEST(CameraEffects, VignettingDarkensTheCornersByOneMinusK) {
  cv::Mat flat(120, 160, CV_32F, cv::Scalar(200));
  applyVignetting(flat, 0.6);
  EXPECT_NEAR(flat.at<float>(0, 0), 200 * 0.4, 2.0);  // r = 1 at the corners
  EXPECT_NEAR(flat.at<float>(119, 159), 200 * 0.4, 2.0);
  EXPECT_NEAR(flat.at<float>(60, 80), 200.0, 0.1);
  // Middle of the left edge: r^2 = 80^2 / (80^2 + 60^2) = 0.64.
  EXPECT_NEAR(flat.at<float>(60, 0), 200 * (1 - 0.6 * 0.64), 2.0);

  // In a rendered sequence: the corners' brightness ratio to the plain render.
  SequenceParams params = smallParams("office_orbit");
  params.max_frames = 2;
  const cv::Mat plain = SequenceRenderer(params).render(1).image;
  params.realism.vignetting = 0.5;
  const cv::Mat vignetted = SequenceRenderer(params).render(1).image;
  const cv::Rect corner(0, 0, 8, 6), centre(76, 57, 8, 6);
  EXPECT_NEAR(cv::mean(vignetted(corner))[0] / cv::mean(plain(corner))[0], 0.52, 0.05);
  EXPECT_NEAR(cv::mean(vignetted(centre))[0] / cv::mean(plain(centre))[0], 1.0, 0.02);
}

TEST(CameraEffects, DefocusSpreadsAnEdgeOverTheDiscOnly) {
  const cv::Mat kernel = defocusKernel(3.0);
  EXPECT_EQ(kernel.rows, 7);
  EXPECT_NEAR(cv::sum(kernel)[0], 1.0, 1e-5);
  EXPECT_FLOAT_EQ(kernel.at<float>(3, 3), kernel.at<float>(3, 2));  // flat inside the disc
  EXPECT_LT(kernel.at<float>(0, 0), 0.1 * kernel.at<float>(3, 3));  // the corner is outside
  cv::Mat edge(40, 40, CV_32F, cv::Scalar(0));
  edge.colRange(20, 40).setTo(cv::Scalar(200));
  applyDefocus(edge, 3.0);
  EXPECT_FLOAT_EQ(edge.at<float>(20, 16), 0.0f);  // 4 px from the edge: untouched
  EXPECT_FLOAT_EQ(edge.at<float>(20, 23), 200.0f);
  EXPECT_GT(edge.at<float>(20, 18), 5.0f);  // within the radius: mixed
  EXPECT_LT(edge.at<float>(20, 21), 195.0f);
  EXPECT_NEAR(edge.at<float>(20, 19) + edge.at<float>(20, 20), 200.0f, 0.1f);  // symmetric
}

TEST(CameraEffects, JpegChangesPixelsButKeepsTheMeanAndTheType) {
  SequenceParams params = smallParams("courtyard_loop");
  params.max_frames = 2;
  params.realism.noise_sigma = 1.0;
  params.realism.vignetting = 1e-9;  // the same float pipeline as the JPEG one
  for (const bool colour : {false, true}) {
    params.color = colour;
    SequenceParams jpeg = params;
    jpeg.realism.jpeg_quality = 75;
    const cv::Mat raw = SequenceRenderer(params).render(1).image;
    const cv::Mat compressed = SequenceRenderer(jpeg).render(1).image;
    SCOPED_TRACE(colour ? "bgr8" : "mono8");
    EXPECT_EQ(compressed.type(), raw.type());
    const double changed = meanAbsDifference(raw, compressed);
    EXPECT_GT(changed, 0.5);  // block artefacts and lost fine texture
    EXPECT_LT(changed, 6.0);
    EXPECT_NEAR(cv::mean(compressed)[0], cv::mean(raw)[0], 1.0);
  }
}

TEST(CameraEffects, RollingShutterChangesRowsProgressivelyAwayFromTheMiddle) {
  SequenceParams params = smallParams("courtyard_loop");
  params.width = 320;
  params.height = 240;
  params.realism.optics_blur = 0.0;
  params.max_frames = 31;
  SequenceParams rolling = params;
  rolling.realism.rolling_shutter = 0.03;
  SequenceRenderer global_renderer(params), rolling_renderer(rolling);
  const RenderedFrame global = global_renderer.render(30), frame = rolling_renderer.render(30);
  // The ground truth is the pose at the middle row's time: the frame's stamp, as without it.
  EXPECT_LT((frame.T_world_cam.matrix() - global.T_world_cam.matrix()).norm(), 1e-12);
  auto band_difference = [&](int centre) {
    const cv::Range rows(centre - 8, centre + 8);
    return meanAbsDifference(global.image.rowRange(rows), frame.image.rowRange(rows));
  };
  const double middle = band_difference(120);
  const double up_half = band_difference(60), top = band_difference(10);
  const double down_half = band_difference(180), bottom = band_difference(230);
  EXPECT_LT(middle, 1.0);
  EXPECT_GT(up_half, 2.0 * middle);
  EXPECT_GT(top, 1.3 * up_half);
  EXPECT_GT(down_half, 2.0 * middle);
  EXPECT_GT(bottom, 1.3 * down_half);
  // Bands of rows at their own pose give almost the same image as every row at its own.
  rolling.realism.rolling_shutter_bands = 30;
  EXPECT_LT(meanAbsDifference(SequenceRenderer(rolling).render(30).image, frame.image), 0.25 * top);
}

TEST(CameraEffects, AutoExposureClipsSunlitHighlightsAndKeepsTheMean) {
  SequenceParams params = smallParams("courtyard_loop");
  SequenceParams sunny = params;
  sunny.realism.auto_exposure = true;
  sunny.realism.sunlight = 3.0;
  SequenceRenderer plain(params), exposed(sunny);
  for (int i = 0; i < 40; i += 13) {
    const cv::Mat a = plain.render(i).image, b = exposed.render(i).image;
    SCOPED_TRACE(i);
    EXPECT_LT(cv::countNonZero(a == 255), 0.001 * a.total());
    EXPECT_GT(cv::countNonZero(b == 255), 0.02 * b.total());  // clipped sunlit patches
    EXPECT_NEAR(cv::mean(b)[0], 110.0, 15.0);
  }
  // A frame's gain depends on the frames before it, not on the order they were rendered in.
  SequenceRenderer ahead(sunny);
  const cv::Mat direct = ahead.render(27).image;
  EXPECT_EQ(meanAbsDifference(direct, exposed.render(27).image), 0.0);
}

TEST(CameraEffects, AutoExposureFollowsABrightnessStepWithALag) {
  AutoExposure controller(110.0, 0.25);
  controller.settle(cv::Mat(20, 20, CV_32F, cv::Scalar(100.0)));
  EXPECT_NEAR(controller.gain(), 1.1, 1e-3);
  const cv::Mat brighter(20, 20, CV_32F, cv::Scalar(200.0));
  for (int frame = 0; frame < 8; ++frame)
    controller.meter(brighter, 1.0 / 30);
  // After 8 frames (0.27 s, about one time constant) about 2/3 of the step is corrected, in log.
  const double corrected = std::log(1.1 / controller.gain()) / std::log(2.0);
  EXPECT_GT(corrected, 0.55);
  EXPECT_LT(corrected, 0.75);
  for (int frame = 0; frame < 60; ++frame)
    controller.meter(brighter, 1.0 / 30);
  EXPECT_NEAR(controller.gain(), 0.55, 0.01);
}

TEST(CameraEffects, SunlightIsFixedInTheWorldAndLightsAboutAThird) {
  const Sunlight sun(1, 3.0);
  cv::RNG rng(5);
  int lit = 0;
  const int n = 4000;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d p(rng.uniform(-20.0, 20.0), rng.uniform(-20.0, 20.0),
                            rng.uniform(0.0, 12.0));
    const float factor = sun.factor(p);
    ASSERT_GE(factor, 1.0f);
    ASSERT_LE(factor, 3.0f);
    lit += factor > 2.0f;
  }
  EXPECT_GT(lit, n / 5);
  EXPECT_LT(lit, n / 2);
}

}  // namespace
}  // namespace scale_drift_slam::sim
