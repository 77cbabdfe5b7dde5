// Relocalisation end to end in the SLAM system (offline, deterministic): the camera is covered
// (black frames), tracking says it is lost, and the camera reappears at a place it mapped earlier,
// far from where it was lost. The loop closer answers the tracker's request (place recognition,
// then P3P and the warped-patch search against the map), tracking resumes within a few frames and
// its poses agree with the truth in the map's frame.

#include <cstdio>

#include <gtest/gtest.h>

#include "../tracking/synthetic_images.h"
#include "scale_drift_slam/evaluation/alignment.h"
#include "scale_drift_slam/geometry/so3.h"
#include "scale_drift_slam/mapping/slam_system.h"

namespace scale_drift_slam::mapping {
namespace {

constexpr int kWidth = 640, kHeight = 480;

std::shared_ptr<const geometry::CameraModel> camera() {
  return tracking::test::pinholeCamera(450.0);
}

geometry::SE3 cameraPose(int k) {
  return tracking::test::sweepPose(k);
}

TEST(Relocalisation, ALostCameraIsFoundAgainInTheMapAndTracksOn) {
  const auto room = tracking::test::boxRoom(4.0, 2.0, 4.0, 40);
  const auto cam = camera();
  SlamParams params;
  params.mapping_thread = false;
  params.loop.recognition.online_training_keyframes = 5;  // a short run: learn the words early
  SlamSystem slam(cam, params);
  const auto render = [&](int k) {
    return tracking::test::renderPlanes(room, cam->K(), cameraPose(k).inverse(), kWidth, kHeight);
  };
  std::vector<Eigen::Vector3d> estimate, truth;
  for (int k = 0; k < 80; ++k) {
    const tracking::FrameResult r =
        slam.processFrame(0.1 * k, render(k), tracking::PixelEncoding::kMono8);
    if (!r.has_pose) continue;
    estimate.push_back(r.T_cam_world.inverseTranslation());
    truth.push_back(cameraPose(k).translation());
  }
  ASSERT_EQ(slam.tracker().state(), tracking::TrackingState::kGood);
  const geometry::Sim3 S_truth_map = evaluation::alignSim3(estimate, truth);

  // Covered: black frames are rejected, and after three of them tracking is lost.
  const cv::Mat black = cv::Mat::zeros(kHeight, kWidth, CV_8UC1);
  for (int i = 0; i < 5; ++i) {
    const tracking::FrameResult r =
        slam.processFrame(8.0 + 0.1 * i, black, tracking::PixelEncoding::kMono8);
    EXPECT_TRUE(r.rejected);
    if (i >= 2) {
      EXPECT_EQ(r.state, tracking::TrackingState::kLost) << r.message;
    }
  }
  // Uncovered where it was at frame 30, about 1.3 m from where it was lost.
  int first_relocalised = -1;
  double worst_error = 0.0;
  for (int k = 30; k < 45; ++k) {
    const tracking::FrameResult r =
        slam.processFrame(9.0 + 0.1 * k, render(k), tracking::PixelEncoding::kMono8);
    if (first_relocalised < 0 && r.relocalised) first_relocalised = k;
    if (first_relocalised < 0 || !r.has_pose) continue;
    EXPECT_NE(r.state, tracking::TrackingState::kLost) << "frame " << k << ": " << r.message;
    const Eigen::Vector3d centre = S_truth_map * r.T_cam_world.inverseTranslation();
    worst_error = std::max(worst_error, (centre - cameraPose(k).translation()).norm());
  }
  std::printf("relocalised at frame %d (shown from frame 30), worst position error after %.4f m\n",
              first_relocalised, worst_error);
  ASSERT_GE(first_relocalised, 30) << "never relocalised";
  EXPECT_LE(first_relocalised, 33);
  EXPECT_LT(worst_error, 0.03);
  EXPECT_GE(slam.relocalisations(), 1);
}

}  // namespace
}  // namespace scale_drift_slam::mapping
