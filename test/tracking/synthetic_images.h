#pragma once
// Test helpers: a reproducible textured image (random rectangles and discs on a smooth
// gradient), corner-rich like a real scene, for the image-based tracking tests.

#include <random>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace scale_drift_slam::tracking::test {

inline cv::Mat texturedImage(int width, int height, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> grey(20, 235);
  cv::Mat image(height, width, CV_8UC1);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      image.at<unsigned char>(y, x) = static_cast<unsigned char>(100 + 50 * x / width);
    }
  }
  std::uniform_real_distribution<double> ux(0, width), uy(0, height), size(4, 30);
  const int shapes = width * height / 500;
  for (int i = 0; i < shapes; ++i) {
    const cv::Point center(static_cast<int>(ux(rng)), static_cast<int>(uy(rng)));
    const int s = static_cast<int>(size(rng));
    if (i % 2 == 0) {
      cv::rectangle(image, center, center + cv::Point(s, s * 2 / 3), cv::Scalar(grey(rng)), -1);
    } else {
      cv::circle(image, center, s / 2, cv::Scalar(grey(rng)), -1, cv::LINE_AA);
    }
  }
  cv::GaussianBlur(image, image, cv::Size(3, 3), 0.8);
  return image;
}

}  // namespace scale_drift_slam::tracking::test
