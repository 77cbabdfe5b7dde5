// The fixed-point NCC of active search against the NCC computed in double precision, and its
// SIMD path against its scalar path (they must give the same integers, so the same scores), on
// random images at every pixel, the image borders included.

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "scale_drift_slam/features/active_search.h"
#include "scale_drift_slam/features/fixed_point_ncc.h"

namespace scale_drift_slam::features {
namespace {

cv::Mat randomImage(int cols, int rows, unsigned seed) {
  cv::Mat image(rows, cols, CV_8UC1);
  cv::RNG rng(seed);
  rng.fill(image, cv::RNG::UNIFORM, 0, 256);
  return image;
}

std::vector<float> randomSamples(int radius, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> value(0.f, 255.f);
  std::vector<float> samples((2 * radius + 1) * (2 * radius + 1));
  for (float& v : samples)
    v = value(rng);
  return samples;
}

TEST(FixedPointNcc, SimdAndScalarScoresAreEqualAtEveryPixel) {
  const cv::Mat image = randomImage(61, 23, 7);
  for (const int radius : {2, 4, 5, 7}) {
    FixedPointTemplate templ;
    ASSERT_TRUE(templ.set(randomSamples(radius, 11 + radius), radius));
    int inside = 0;
    for (int y = -1; y <= image.rows; ++y) {
      for (int x = -1; x <= image.cols; ++x) {
        const double simd = templ.score(image, x, y), scalar = templ.scoreScalar(image, x, y);
        ASSERT_EQ(simd, scalar) << "r " << radius << " at " << x << ", " << y;
        inside += simd > -2.0;
      }
    }
    EXPECT_EQ(inside, (image.cols - 2 * radius) * (image.rows - 2 * radius));
  }
}

TEST(FixedPointNcc, EqualsTheNccInDoublePrecision) {
  const cv::Mat image = randomImage(40, 40, 3);
  for (const int radius : {2, 4, 7}) {
    const std::vector<float> samples = randomSamples(radius, 5 + radius);
    FixedPointTemplate templ;
    ASSERT_TRUE(templ.set(samples, radius));
    const int n = static_cast<int>(samples.size());
    for (int y = radius; y + radius < image.rows; y += 3) {
      for (int x = radius; x + radius < image.cols; x += 2) {
        std::vector<float> patch;
        for (int dy = -radius; dy <= radius; ++dy)
          for (int dx = -radius; dx <= radius; ++dx)
            patch.push_back(image.at<unsigned char>(y + dy, x + dx));
        // The template's fixed point rounds each value to 1/16384 of its norm.
        EXPECT_NEAR(templ.score(image, x, y),
                    normalizedCrossCorrelation(samples.data(), patch.data(), n), 2e-4);
      }
    }
  }
}

TEST(FixedPointNcc, ATemplateOrPatchWithoutTextureScoresNothing) {
  FixedPointTemplate templ;
  EXPECT_FALSE(templ.set(std::vector<float>(81, 90.f), 4));
  EXPECT_TRUE(templ.empty());
  ASSERT_TRUE(templ.set(randomSamples(4, 1), 4));
  const cv::Mat flat(30, 30, CV_8UC1, cv::Scalar(128));
  EXPECT_EQ(templ.score(flat, 15, 15), -1.0);
  EXPECT_EQ(templ.score(flat, 3, 15), -2.0);  // the patch leaves the image
  EXPECT_THROW(templ.set(std::vector<float>(80, 1.f), 4), std::invalid_argument);
}

TEST(FixedPointNcc, ScoresOneWhereTheImageIsTheTemplateUnderGainAndBias) {
  const std::vector<float> samples = randomSamples(4, 21);
  cv::Mat image(20, 30, CV_8UC1, cv::Scalar(0));
  for (int dy = 0; dy < 9; ++dy)
    for (int dx = 0; dx < 9; ++dx)
      image.at<unsigned char>(5 + dy, 11 + dx) =
          cv::saturate_cast<unsigned char>(0.5f * samples[dy * 9 + dx] + 60.f);
  FixedPointTemplate templ;
  ASSERT_TRUE(templ.set(samples, 4));
  // 0.5 * v rounds to the nearest level: the score is ~1, not exactly 1.
  EXPECT_GT(templ.score(image, 15, 9), 0.999);
  EXPECT_LT(templ.score(image, 16, 9), 0.5);
}

}  // namespace
}  // namespace scale_drift_slam::features
