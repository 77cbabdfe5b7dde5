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
#include "scale_drift_slam/system/slam_system.h"
#include "scale_drift_slam/tracking/tracker.h"

namespace scale_drift_slam::system {
namespace {

constexpr int kWidth = 640, kHeight = 480;

std::shared_ptr<const geometry::CameraModel> camera() {
  return test::pinholeCamera(450.0);
}

geometry::SE3 cameraPose(int k) {
  return test::sweepPose(k);
}

/// What the camera sees of the room at pose k of the sweep.
cv::Mat renderView(const std::vector<test::TexturedPlane>& room, const geometry::CameraModel& cam,
                   int k) {
  return test::renderPlanes(room, cam.K(), cameraPose(k).inverse(), kWidth, kHeight);
}

/// Maps the room over frames 0-79 of the sweep, covers the camera (five black frames: lost) and
/// uncovers it where it was at frame 30, about 1.3 m from where it was lost; frames 30-44 follow.
/// Returns the first frame with a pose after the cover (-1: none) and the worst position error
/// from there; `relocalised` says whether that first pose came from the loop closer's answer.
struct Uncovered {
  int first_posed = -1;
  bool relocalised = false;
  double worst_error = 0.0;
  int relocalisations = 0;
};

Uncovered coverAndUncover(bool recover_from_keyframe) {
  const auto room = test::boxRoom(4.0, 2.0, 4.0, 40);
  const auto cam = camera();
  system::SlamParams params;
  params.mapping_thread = false;
  params.loop.recognition.online_training_keyframes = 5;  // a short run: learn the words early
  params.tracker.recover_from_keyframe = recover_from_keyframe;
  system::SlamSystem slam(cam, params);
  const auto render = [&](int k) { return renderView(room, *cam, k); };
  std::vector<Eigen::Vector3d> estimate, truth;
  for (int k = 0; k < 80; ++k) {
    const tracking::FrameResult r =
        slam.processFrame(0.1 * k, render(k), features::PixelEncoding::kMono8);
    if (!r.has_pose) continue;
    estimate.push_back(r.T_cam_world.inverseTranslation());
    truth.push_back(cameraPose(k).translation());
  }
  EXPECT_EQ(slam.tracker().state(), tracking::TrackingState::kGood);
  if (slam.tracker().state() != tracking::TrackingState::kGood) return {};
  const geometry::Sim3 S_truth_map = evaluation::alignSim3(estimate, truth);

  // Covered: black frames are rejected, and after three of them tracking is lost.
  const cv::Mat black = cv::Mat::zeros(kHeight, kWidth, CV_8UC1);
  for (int i = 0; i < 5; ++i) {
    const tracking::FrameResult r =
        slam.processFrame(8.0 + 0.1 * i, black, features::PixelEncoding::kMono8);
    EXPECT_TRUE(r.rejected);
    if (i >= 2) {
      EXPECT_EQ(r.state, tracking::TrackingState::kLost) << r.message;
    }
  }
  // Uncovered where it was at frame 30, about 1.3 m from where it was lost.
  Uncovered result;
  for (int k = 30; k < 45; ++k) {
    const tracking::FrameResult r =
        slam.processFrame(9.0 + 0.1 * k, render(k), features::PixelEncoding::kMono8);
    if (result.first_posed < 0 && r.has_pose) {
      result.first_posed = k;
      result.relocalised = r.relocalised;
    }
    if (result.first_posed < 0 || !r.has_pose) continue;
    EXPECT_NE(r.state, tracking::TrackingState::kLost) << "frame " << k << ": " << r.message;
    const Eigen::Vector3d centre = S_truth_map * r.T_cam_world.inverseTranslation();
    result.worst_error =
        std::max(result.worst_error, (centre - cameraPose(k).translation()).norm());
  }
  result.relocalisations = slam.relocalisations();
  return result;
}

TEST(Relocalisation, ALostCameraIsFoundAgainInTheMapAndTracksOn) {
  // The loop closer's relocalisation alone: the tracker's own recovery from its newest keyframe
  // (next test) would find this place first.
  const Uncovered u = coverAndUncover(false);
  std::printf("relocalised at frame %d (shown from frame 30), worst position error after %.4f m\n",
              u.first_posed, u.worst_error);
  ASSERT_GE(u.first_posed, 30) << "never relocalised";
  EXPECT_TRUE(u.relocalised);
  EXPECT_LE(u.first_posed, 33);
  EXPECT_LT(u.worst_error, 0.03);
  EXPECT_GE(u.relocalisations, 1);
}

// The same cover, with the tracker's recovery from its newest keyframe (tracker.
// recover_from_keyframe): much of the far wall seen at frame 30 is in the newest keyframe's view,
// whose points, matched by descriptor, give the pose at once, without waiting for the loop closer.
TEST(Relocalisation, ALostCameraBackInViewOfTheNewestKeyframeRecoversByItself) {
  const Uncovered u = coverAndUncover(true);
  std::printf("recovered at frame %d (shown from frame 30), worst position error after %.4f m\n",
              u.first_posed, u.worst_error);
  ASSERT_EQ(u.first_posed, 30) << "not recovered at the first uncovered frame";
  EXPECT_FALSE(u.relocalised);
  EXPECT_LT(u.worst_error, 0.03);
}

// A request ends when tracking recovers by itself: lost again later, the tracker asks afresh
// (appending the new frames to the old request would leave a gap of tracked frames that a late
// answer would be carried across by flow), and the old request's answer is refused.
TEST(Relocalisation, ARequestEndsWhenTrackingRecoversByItself) {
  const auto room = test::boxRoom(4.0, 2.0, 4.0, 40);
  const auto cam = camera();
  tracking::Tracker tracker(cam, tracking::TrackerParams{});
  const auto process = [&](double t, const cv::Mat& image) {
    return tracker.processFrame(t, image, features::PixelEncoding::kMono8);
  };
  const auto render = [&](int k) { return renderView(room, *cam, k); };
  for (int k = 0; k < 30; ++k)
    process(0.1 * k, render(k));
  ASSERT_EQ(tracker.state(), tracking::TrackingState::kGood);
  // Something else entirely (textured, so not rejected as blank): lost, a request goes out.
  const cv::Mat elsewhere = test::texturedImage(kWidth, kHeight, 99);
  const tracking::FrameResult first_loss = process(3.0, elsewhere);
  ASSERT_EQ(first_loss.state, tracking::TrackingState::kLost) << first_loss.message;
  ASSERT_TRUE(first_loss.relocalisation_request.has_value());
  // Back where it was: found again without an answer.
  const tracking::FrameResult recovered = process(3.1, render(29));
  ASSERT_NE(recovered.state, tracking::TrackingState::kLost) << recovered.message;
  EXPECT_FALSE(recovered.relocalised);
  // Lost again (well within relocalisation_retry_frames): a new request, not more frames for
  // the old one.
  const tracking::FrameResult second_loss = process(3.2, elsewhere);
  ASSERT_EQ(second_loss.state, tracking::TrackingState::kLost) << second_loss.message;
  ASSERT_TRUE(second_loss.relocalisation_request.has_value());
  EXPECT_GT(second_loss.relocalisation_request->frame_index,
            first_loss.relocalisation_request->frame_index);
  map::RelocalisationAnswer stale;
  stale.frame_index = first_loss.relocalisation_request->frame_index;
  stale.success = true;
  EXPECT_FALSE(tracker.applyRelocalisation(stale));
}

// The tracker's recovery from the previous frame: the camera rolls 30 degrees in place after the
// last keyframe (no keyframe: it has not moved), then jumps 1.5 m sideways (frames dropped: ~145 px
// of image motion the flow and the search around it cannot carry). The newest keyframe's upright
// descriptors, 30 degrees away, match too few of the frame's corners; the previous frame's inliers,
// described in the rolled view, give the pose at once.
TEST(Relocalisation, AJumpAfterTheViewRolledAwayFromTheNewestKeyframeRecoversFromThePreviousFrame) {
  const auto room = test::boxRoom(4.0, 2.0, 4.0, 40);
  const auto cam = camera();
  tracking::Tracker tracker(cam, tracking::TrackerParams{});
  std::vector<Eigen::Vector3d> estimate, truth;
  const auto process = [&](double t, const geometry::SE3& T_world_cam) {
    const cv::Mat image =
        test::renderPlanes(room, cam->K(), T_world_cam.inverse(), kWidth, kHeight);
    const tracking::FrameResult r = tracker.processFrame(t, image, features::PixelEncoding::kMono8);
    if (r.has_pose) {
      estimate.push_back(r.T_cam_world.inverseTranslation());
      truth.push_back(T_world_cam.translation());
    }
    return r;
  };
  for (int k = 0; k < 30; ++k)
    process(0.1 * k, cameraPose(k));
  ASSERT_EQ(tracker.state(), tracking::TrackingState::kGood);
  const std::size_t keyframes = tracker.trackingMap().numKeyframes();
  const auto rolled = [](double degrees, const Eigen::Vector3d& shift) {
    return geometry::SE3(Eigen::Matrix3d::Identity(), shift) * cameraPose(29) *
           geometry::SE3(geometry::expSO3(Eigen::Vector3d(0.0, 0.0, degrees * M_PI / 180.0)),
                         Eigen::Vector3d::Zero());
  };
  for (int j = 1; j <= 20; ++j) {
    const tracking::FrameResult r =
        process(3.0 + 0.1 * j, rolled(1.5 * j, Eigen::Vector3d::Zero()));
    ASSERT_TRUE(r.has_pose) << "roll frame " << j << ": " << r.message;
  }
  ASSERT_EQ(tracker.trackingMap().numKeyframes(), keyframes) << "a keyframe in the roll";
  const geometry::SE3 jumped = rolled(30.0, Eigen::Vector3d(1.5, 0.0, 0.0));
  const tracking::FrameResult r = process(5.1, jumped);
  ASSERT_TRUE(r.has_pose) << "the jump: " << r.message;
  EXPECT_EQ(r.state, tracking::TrackingState::kGood) << r.message;
  // The pose against the truth, in the frame of the map (aligned over all the posed frames).
  const geometry::Sim3 S_truth_map = evaluation::alignSim3(estimate, truth);
  const double error =
      (S_truth_map * r.T_cam_world.inverseTranslation() - jumped.translation()).norm();
  std::printf("after the jump: %d inliers, position error %.4f m\n", r.num_inliers, error);
  EXPECT_LT(error, 0.03);
}

// Lost in a map too young to relocalise in (no vocabulary yet): after restart_after_lost_frames
// lost frames the tracker discards it and initialises again; the mapper and the loop closer follow,
// and the new map is built from the new keyframes only.
TEST(Relocalisation, AYoungMapLostTooLongIsDiscardedAndANewOneStarts) {
  const auto room = test::boxRoom(4.0, 2.0, 4.0, 40);
  const auto cam = camera();
  for (const bool thread : {false, true}) {
    system::SlamParams params;
    params.mapping_thread = thread;
    params.tracker.restart_after_lost_frames = 6;
    system::SlamSystem slam(cam, params);
    const auto process = [&](double t, const cv::Mat& image) {
      return slam.processFrame(t, image, features::PixelEncoding::kMono8);
    };
    const auto render = [&](int k) { return renderView(room, *cam, k); };
    for (int k = 0; k < 30; ++k)
      process(0.1 * k, render(k));
    ASSERT_EQ(slam.tracker().state(), tracking::TrackingState::kGood);
    const std::size_t young_keyframes = slam.tracker().trackingMap().numKeyframes();
    ASSERT_LT(young_keyframes, 30u);

    const cv::Mat black = cv::Mat::zeros(kHeight, kWidth, CV_8UC1);
    int restarted_at = -1;
    for (int i = 0; i < 10; ++i) {
      const tracking::FrameResult r = process(3.0 + 0.1 * i, black);
      if (r.map_restarted) {
        EXPECT_EQ(restarted_at, -1) << "restarted twice";
        restarted_at = i;
        EXPECT_EQ(r.state, tracking::TrackingState::kInitializing) << r.message;
        EXPECT_NE(r.message.find("initialising again"), std::string::npos) << r.message;
      }
    }
    // Lost at the third black frame, discarded six lost frames later.
    EXPECT_EQ(restarted_at, 7);
    EXPECT_EQ(slam.mapRestarts(), 1);
    EXPECT_EQ(slam.tracker().trackingMap().numKeyframes(), 0u);

    // The camera is uncovered somewhere else: a new map, tracked against the truth.
    std::vector<Eigen::Vector3d> estimate, truth;
    for (int k = 40; k < 80; ++k) {
      const tracking::FrameResult r = process(4.0 + 0.1 * k, render(k));
      if (!r.has_pose) continue;
      estimate.push_back(r.T_cam_world.inverseTranslation());
      truth.push_back(cameraPose(k).translation());
    }
    slam.finish();
    ASSERT_GE(estimate.size(), 30u) << "the new map did not start";
    EXPECT_EQ(slam.tracker().state(), tracking::TrackingState::kGood);
    const geometry::Sim3 S = evaluation::alignSim3(estimate, truth);
    double worst = 0.0;
    for (std::size_t i = 0; i < estimate.size(); ++i)
      worst = std::max(worst, (S * estimate[i] - truth[i]).norm());
    EXPECT_LT(worst, 0.03);
    // The mapper holds the new map only, the corrected trajectory the new map's frames only.
    EXPECT_EQ(slam.map().numKeyframes(), slam.tracker().trackingMap().numKeyframes());
    EXPECT_EQ(slam.trajectory().frames().size(), estimate.size());
    EXPECT_GE(slam.trajectory().frames().front().timestamp, 8.0);
  }
}

}  // namespace
}  // namespace scale_drift_slam::system
