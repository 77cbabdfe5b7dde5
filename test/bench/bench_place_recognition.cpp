// Place recognition figures (doc/place_recognition.md): keyframe appearance extraction per
// 640x480 image (ORB, with BRISK and AKAZE for the choice), vocabulary training, size and load
// time, and the query time with 1000 keyframes in the database, on procedural views
// (test/loop/synthetic_views.h). Single-threaded OpenCV. Measures; asserts nothing about time.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>

#include <opencv2/core/utility.hpp>

#include "../loop/synthetic_views.h"
#include "bench_report.h"
#include "scale_drift_slam/loop/place_recognizer.h"

namespace sds = scale_drift_slam;
using sds::loop::testing::makeTexture;
using sds::loop::testing::renderView;
using sds::loop::testing::ViewPose;

namespace {

ViewPose at(double x, double y) {
  ViewPose pose;
  pose.x = x;
  pose.y = y;
  return pose;
}

/// Detector comparison on one pair with a known homography: time, matches passing the ratio
/// test, and the share of them that are correct (within 3 px of the true position).
void compareDescriptors(sds::bench::Report& report) {
  const cv::Mat texture = makeTexture(3000, 900, 7);
  const ViewPose first = at(1000, 450);
  ViewPose second = at(1060, 450);
  second.angle_deg = 8.0;
  second.scale = 1.15;
  second.tilt_x = 2e-4;
  second.gain = 0.8;
  second.bias = 20.0;
  const cv::Mat a = renderView(texture, first, 1);
  const cv::Mat b = renderView(texture, second, 2);
  const cv::Matx33d H_b_a = sds::loop::testing::viewToTexture(second, a.size()).inv() *
                            sds::loop::testing::viewToTexture(first, a.size());
  const std::vector<std::pair<std::string, cv::Ptr<cv::Feature2D>>> detectors = {
      {"ORB", cv::ORB::create(1000)},
      {"BRISK", cv::BRISK::create()},
      {"AKAZE", cv::AKAZE::create()}};
  for (const auto& named : detectors) {
    const std::string& name = named.first;
    const cv::Ptr<cv::Feature2D>& detector = named.second;
    std::vector<cv::KeyPoint> keypoints_a;
    std::vector<cv::KeyPoint> keypoints_b;
    cv::Mat descriptors_a;
    cv::Mat descriptors_b;
    report.timeMs(name + " detect+describe 640x480 (OpenCV defaults)", 10, [&] {
      keypoints_a.clear();
      detector->detectAndCompute(a, cv::noArray(), keypoints_a, descriptors_a);
    });
    detector->detectAndCompute(b, cv::noArray(), keypoints_b, descriptors_b);
    std::vector<std::vector<cv::DMatch>> knn;
    cv::BFMatcher(cv::NORM_HAMMING).knnMatch(descriptors_a, descriptors_b, knn, 2);
    int good = 0;
    int correct = 0;
    for (const auto& pair : knn) {
      if (pair.size() < 2 || pair[0].distance > 0.8 * pair[1].distance) continue;
      ++good;
      const cv::Point2f& p = keypoints_a[static_cast<std::size_t>(pair[0].queryIdx)].pt;
      const cv::Vec3d h = H_b_a * cv::Vec3d(p.x, p.y, 1.0);
      const cv::Point2f predicted(static_cast<float>(h[0] / h[2]), static_cast<float>(h[1] / h[2]));
      if (cv::norm(predicted - keypoints_b[static_cast<std::size_t>(pair[0].trainIdx)].pt) < 3.0) {
        ++correct;
      }
    }
    report.add(name + " keypoints / descriptor bytes", static_cast<double>(keypoints_a.size()), "",
               std::to_string(descriptors_a.cols) + " bytes each");
    report.add(name + " correct ratio-test matches (rotated, zoomed view)",
               100.0 * correct / std::max(1, good), "%",
               std::to_string(correct) + " of " + std::to_string(good));
  }
}

}  // namespace

namespace {

int run(int argc, char** argv) {
  cv::setNumThreads(1);
  sds::bench::Report report("place_recognition", argc, argv);
  compareDescriptors(report);

  // 1000 keyframes: a sideways walk along 10 different walls, 100 keyframes each.
  const sds::loop::PlaceRecognitionParams params;
  sds::loop::AppearanceExtractor extractor(params.appearance);
  std::vector<cv::Mat> walls;
  std::vector<sds::loop::KeyframeAppearance> appearances;
  for (int w = 0; w < 10; ++w) {
    walls.push_back(makeTexture(8400, 900, 100 + static_cast<std::uint32_t>(w)));
    for (int k = 0; k < 100; ++k) {
      appearances.push_back(extractor.extract(
          renderView(walls.back(), at(400 + 76.0 * k, 450), static_cast<std::uint32_t>(k))));
    }
  }
  const cv::Mat image = renderView(walls[3], at(2000, 430), 5);
  report.timeMs("appearance extraction (ours: ORB 1000, grid-spread) 640x480", 20,
                [&] { extractor.extract(image); });

  std::vector<cv::Mat> training;
  training.reserve(static_cast<std::size_t>(params.online_training_keyframes));
  for (int k = 0; k < params.online_training_keyframes; ++k) {
    training.push_back(appearances[static_cast<std::size_t>(k)].descriptors);
  }
  auto vocabulary = std::make_shared<sds::loop::Vocabulary>();
  report.timeMs("online vocabulary training (k=10, L=4, 30 keyframes)", 3,
                [&] { *vocabulary = sds::loop::Vocabulary::train(training, params.vocabulary); });
  report.add("online vocabulary words", static_cast<double>(vocabulary->numWords()), "");
  const std::string path = "/tmp/bench_place_recognition_vocabulary.bin";
  vocabulary->save(path);
  report.add(
      "vocabulary file size (k=10, L=4)",
      static_cast<double>(std::ifstream(path, std::ios::ate | std::ios::binary).tellg()) / 1024.0,
      "kB");
  report.timeMs("vocabulary load", 20, [&] { sds::loop::Vocabulary::load(path); });

  sds::loop::PlaceRecognizer recognizer(params, vocabulary);
  for (std::size_t k = 0; k < appearances.size(); ++k) {
    recognizer.add(static_cast<sds::map::KeyframeId>(k), 0.5 * k, appearances[k]);
  }
  report.add("keyframes in the database before the queries", static_cast<double>(recognizer.size()),
             "");
  // A revisit of wall 3 (one keyframe every 76 px, a little lower and rotated), each keyframe
  // queried then added, as the loop-closure thread does: the retrieval part (bag of words +
  // inverted-index scores) and the whole query (islands, geometric checks of up to 3 islands,
  // consistency).
  std::vector<sds::loop::KeyframeAppearance> queries;
  for (int q = 0; q < 40; ++q) {
    ViewPose pose = at(600 + 76.0 * q + 38.0, 430);
    pose.angle_deg = 3.0;
    queries.push_back(extractor.extract(renderView(walls[3], pose, 500 + q)));
  }
  std::vector<float> scores;
  sds::loop::BowDatabase database;
  for (const auto& a : appearances)
    database.add(vocabulary->transform(a.descriptors));
  std::size_t next = 0;
  report.timeMs("retrieval at 1000 keyframes (bag of words + scores)", 40, [&] {
    const auto bow = vocabulary->transform(queries[next++ % queries.size()].descriptors);
    database.scoreAll(bow, scores);
  });
  int accepted = 0;
  int checked = 0;
  std::vector<double> query_ms;
  for (std::size_t q = 0; q < queries.size(); ++q) {
    const auto id = static_cast<sds::map::KeyframeId>(1000 + q);
    const auto start = std::chrono::steady_clock::now();
    const auto result = recognizer.query(id, 500.0 + 0.5 * q, queries[q]);
    query_ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
            .count());
    accepted += result.accepted() != nullptr ? 1 : 0;
    checked += static_cast<int>(result.candidates.size());
    recognizer.add(id, 500.0 + 0.5 * q, queries[q]);
  }
  std::sort(query_ms.begin(), query_ms.end());
  report.add("whole query at 1000-1040 keyframes (with geometric checks)",
             query_ms[query_ms.size() / 2], "ms",
             "median of 40; p95 " + std::to_string(query_ms[query_ms.size() * 95 / 100]) +
                 ", max " + std::to_string(query_ms.back()));
  report.add("islands checked geometrically per query", checked / 40.0, "");
  report.add("loops accepted in the 40 revisit queries", accepted, "", "sanity: expect 1");

  sds::loop::FeatureGroups groups_a;
  sds::loop::FeatureGroups groups_b;
  const sds::loop::KeyframeAppearance& a = appearances[300];
  const sds::loop::KeyframeAppearance& b = appearances[302];
  vocabulary->transform(a.descriptors, groups_a, params.geometry.group_levels_up);
  vocabulary->transform(b.descriptors, groups_b, params.geometry.group_levels_up);
  report.timeMs("geometric check of one candidate (grouped matching + RANSAC)", 30, [&] {
    sds::loop::checkGeometry(a, b,
                             sds::loop::matchDescriptors(a, groups_a, b, groups_b, params.geometry),
                             params.geometry);
  });
  report.timeMs("geometric check of one candidate (brute-force matching + RANSAC)", 10, [&] {
    sds::loop::checkGeometry(a, b, sds::loop::matchDescriptors(a, b, params.geometry),
                             params.geometry);
  });
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_place_recognition: %s\n", e.what());
    return 1;
  }
}
