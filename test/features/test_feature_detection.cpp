// FAST corners spread by the quadtree: the selection covers the image evenly (every quadrant of a
// corner-rich image gets its share), respects the budget and the occupied pixels, and the corner
// grid returns exactly the corners inside a box.

#include <memory>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "../tracking/synthetic_images.h"
#include "scale_drift_slam/features/feature_detection.h"

namespace scale_drift_slam::features {
namespace {

TEST(FeatureDetection, QuadtreeSpreadsClusteredCorners) {
  // 900 strong corners crowded in the top-left 100x100 pixels, 100 weak ones spread elsewhere.
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> crowd(0.f, 100.f), spread(0.f, 640.f), spread_y(0.f, 480.f);
  std::vector<cv::KeyPoint> corners;
  for (int i = 0; i < 900; ++i)
    corners.emplace_back(crowd(rng), crowd(rng), 7.f, -1.f, 100.f);
  for (int i = 0; i < 100; ++i)
    corners.emplace_back(spread(rng), spread_y(rng), 7.f, -1.f, 10.f);
  const auto selected = distributeQuadtree(corners, 100, 640, 480);
  ASSERT_EQ(selected.size(), 100u);
  int in_crowd = 0;
  for (const auto& k : selected)
    in_crowd += (k.pt.x < 100.f && k.pt.y < 100.f) ? 1 : 0;
  // The crowd covers 3% of the image: the strongest-first choice would take 100 of it.
  EXPECT_LT(in_crowd, 40);
  EXPECT_TRUE(distributeQuadtree(corners, 0, 640, 480).empty());
  EXPECT_EQ(distributeQuadtree(corners, 5000, 640, 480).size(), corners.size());
}

TEST(FeatureDetection, SpreadCornersCoverTheImageAndAvoidOccupiedPixels) {
  const cv::Mat image = test::texturedImage(640, 480, 5);
  FeatureDetectionParams params;
  const std::vector<Eigen::Vector2d> occupied = {{320, 240}, {100, 100}};
  const auto corners = detectSpreadCorners(image, 200, params, occupied);
  ASSERT_GE(corners.size(), 150u);
  ASSERT_LE(corners.size(), 200u);
  int quadrant_count[4] = {0, 0, 0, 0};
  for (const auto& k : corners) {
    quadrant_count[(k.pt.x >= 320 ? 1 : 0) + (k.pt.y >= 240 ? 2 : 0)]++;
    EXPECT_GE(k.pt.x, params.border);
    EXPECT_LT(k.pt.x, 640 - params.border);
    for (const auto& o : occupied) {
      EXPECT_GE((Eigen::Vector2d(k.pt.x, k.pt.y) - o).norm(), params.min_distance);
    }
  }
  for (int count : quadrant_count)
    EXPECT_GT(count, 25);
  // A blank image has no corners; a tiny one must not crash.
  EXPECT_TRUE(detectSpreadCorners(cv::Mat(480, 640, CV_8UC1, cv::Scalar(9)), 50, params).empty());
  EXPECT_TRUE(detectSpreadCorners(cv::Mat(5, 5, CV_8UC1, cv::Scalar(9)), 50, params).empty());
}

TEST(FeatureDetection, CornerGridQueriesTheBox) {
  std::mt19937 rng(6);
  std::uniform_real_distribution<float> ux(0.f, 639.f), uy(0.f, 479.f);
  std::vector<cv::KeyPoint> corners;
  for (int i = 0; i < 2000; ++i)
    corners.emplace_back(ux(rng), uy(rng), 1.f);
  const CornerGrid grid(corners, 640, 480);
  std::vector<int> found;
  for (const Eigen::Vector2d& center : {Eigen::Vector2d(300, 200), Eigen::Vector2d(5, 470)}) {
    grid.query(center, 25.0, 12.0, &found);
    int expected = 0;
    for (const auto& k : corners) {
      expected += (std::abs(k.pt.x - center.x()) <= 25 && std::abs(k.pt.y - center.y()) <= 12);
    }
    EXPECT_EQ(static_cast<int>(found.size()), expected);
    for (int i : found)
      EXPECT_LE(std::abs(corners[i].pt.x - center.x()), 25);
  }
  grid.query(Eigen::Vector2d(NAN, 3), 5, 5, &found);
  EXPECT_TRUE(found.empty());
}

// A frame's corners are detected once per border: those of a higher threshold are filtered from
// the first detection and are exactly the corners a detection of their own finds, whichever
// caller asked first. A lower threshold detects again.
TEST(FeatureDetection, ACornerCacheAnswersAsADetectionOfItsOwnWhateverTheOrder) {
  const cv::Mat image = test::texturedImage(640, 480, 9);
  auto positions = [](const std::vector<cv::KeyPoint>& corners) {
    std::set<std::pair<float, float>> kept;
    for (const cv::KeyPoint& k : corners)
      kept.insert({k.pt.x, k.pt.y});
    return kept;
  };
  const ImagePyramid pyramid = buildPyramid(image, 3);
  const std::shared_ptr<FastCornerCache> cache = pyramid.corners();
  ASSERT_EQ(cache, pyramid.corners());  // shared, not made again
  // The wide border first, the narrow one next (the order the lost map's search and the next
  // map's initializer ask in), then a lower threshold, then the first question again.
  const std::vector<std::pair<int, int>> questions = {{20, 12}, {8, 5}, {6, 12}, {20, 12}, {8, 3}};
  std::size_t wide_count = 0, narrow_count = 0;
  for (const auto& [threshold, border] : questions) {
    const std::vector<cv::KeyPoint> cached = cache->detect(threshold, border);
    const std::vector<cv::KeyPoint> own = detectFast(image, threshold, border);
    ASSERT_GT(own.size(), 200u);
    EXPECT_EQ(positions(cached), positions(own)) << threshold << " " << border;
    for (const cv::KeyPoint& k : cached) {
      EXPECT_GE(k.response, static_cast<float>(threshold));
      EXPECT_TRUE(k.pt.x >= border && k.pt.y >= border && k.pt.x < image.cols - border &&
                  k.pt.y < image.rows - border);
    }
    if (threshold == 20) wide_count = own.size();
    if (border == 5) narrow_count = own.size();
  }
  EXPECT_LT(wide_count, narrow_count);
  // A pyramid's first spread corners are those of the image alone.
  FeatureDetectionParams params;
  EXPECT_EQ(positions(detectSpreadCorners(buildPyramid(image, 3), 150, params)),
            positions(detectSpreadCorners(image, 150, params)));
}

}  // namespace
}  // namespace scale_drift_slam::features
