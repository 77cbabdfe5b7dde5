// The loop closer keeps each keyframe's image as a JPEG for loop verification: one buffer of
// exactly the JPEG's size per keyframe (imencode's own buffer grows by doubling and would keep up
// to twice that, ~130 kB per KITTI-sized keyframe; issue 18, memory per keyframe), and the image
// it gives back is the keyframe's.

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "../tracking/synthetic_images.h"

#include "scale_drift_slam/loop/loop_closer.h"

namespace scale_drift_slam::loop {
namespace {

map::KeyframeMessage keyframeWithImage(map::KeyframeId id) {
  map::KeyframeMessage message;
  message.keyframe.id = id;
  message.keyframe.timestamp = 0.1 * static_cast<double>(id);
  message.keyframe.T_kf_world =
      geometry::SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-0.1 * id, 0.0, 0.0));
  for (map::PointId k = 0; k < 2; ++k) {
    const map::PointId point = 2 * id + k;
    message.new_points.push_back({point, Eigen::Vector3d(0.1 * id, 0.2 * k, 2.0), id});
    message.keyframe.observations.push_back({point, Eigen::Vector2d(0.01 * k, 0.02)});
  }
  cv::Mat image = test::texturedImage(640, 480, 11 + static_cast<unsigned>(id));
  cv::Mat noise(image.size(), CV_8UC1);
  cv::randu(noise, 0, 8);  // sensor noise: the JPEG gets large, as a real one does
  message.image = image + noise;
  return message;
}

TEST(LoopCloserImages, EachKeyframeImageIsStoredInABufferOfItsOwnSize) {
  LoopCloser closer(test::pinholeCamera(500.0), LoopCloserParams{});
  std::vector<cv::Mat> images;
  for (map::KeyframeId id = 0; id < 4; ++id) {
    map::KeyframeMessage message = keyframeWithImage(id);
    images.push_back(message.image.clone());
    closer.addKeyframe(std::move(message));
  }
  ASSERT_EQ(closer.keyframeImages().size(), 4u);
  for (map::KeyframeId id = 0; id < 4; ++id) {
    const std::vector<std::uint8_t>& jpeg = closer.keyframeImages().at(id);
    ASSERT_GT(jpeg.size(), 10000u) << id;
    EXPECT_EQ(jpeg.capacity(), jpeg.size()) << id;
    const cv::Mat decoded = cv::imdecode(jpeg, cv::IMREAD_GRAYSCALE);
    ASSERT_EQ(decoded.size(), images[id].size()) << id;
    // The keyframe's own image (JPEG: a grey level or two off on average), not another's.
    EXPECT_LT(cv::norm(decoded, images[id], cv::NORM_L1) / images[id].total(), 3.0) << id;
    if (id > 0)
      EXPECT_GT(cv::norm(decoded, images[id - 1], cv::NORM_L1) / images[id].total(), 10.0);
  }
}

}  // namespace
}  // namespace scale_drift_slam::loop
