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

// Lost in a map too young to relocalise in by place recognition (no vocabulary yet): after
// restart_after_lost_frames lost frames the tracker also initialises a new map from the frames
// that follow, keeping the young map (still lost, still relocalising against its newest
// keyframes) until the new one starts.
struct YoungMapRun {
  std::size_t young_keyframes = 0;
  int restarted_at = -1;  ///< Frame (of the second part) where the young map was discarded.
  int restarts = 0;
  std::vector<Eigen::Vector3d> estimate, truth;  ///< The posed frames of the second part.
  std::vector<Eigen::Vector3d> young_estimate, young_truth;  ///< ...and of the first.
  int first_posed = -1;  ///< The first posed frame of the second part.
  std::size_t trajectory_frames = 0, map_keyframes = 0, tracker_keyframes = 0;
  double first_trajectory_stamp = 0.0;
  tracking::TrackingState state = tracking::TrackingState::kInitializing;
};

/// Maps `room` over frames 0-29 of the sweep, covers the camera for ten black frames (lost at the
/// third), then shows it `next_room` from frames 40-79.
YoungMapRun loseAYoungMap(bool thread, const std::vector<test::TexturedPlane>& room,
                          const std::vector<test::TexturedPlane>& next_room) {
  const auto cam = camera();
  system::SlamParams params;
  params.mapping_thread = thread;
  params.tracker.restart_after_lost_frames = 6;
  system::SlamSystem slam(cam, params);
  const auto process = [&](double t, const cv::Mat& image) {
    return slam.processFrame(t, image, features::PixelEncoding::kMono8);
  };
  YoungMapRun run;
  for (int k = 0; k < 30; ++k) {
    const tracking::FrameResult r = process(0.1 * k, renderView(room, *cam, k));
    if (!r.has_pose) continue;
    run.young_estimate.push_back(r.T_cam_world.inverseTranslation());
    run.young_truth.push_back(cameraPose(k).translation());
  }
  EXPECT_EQ(slam.tracker().state(), tracking::TrackingState::kGood);
  run.young_keyframes = slam.tracker().trackingMap().numKeyframes();
  EXPECT_LT(run.young_keyframes, 30u);
  // Nothing to start a new map from while covered: the young map stays, however long.
  const cv::Mat black = cv::Mat::zeros(kHeight, kWidth, CV_8UC1);
  for (int i = 0; i < 10; ++i) {
    const tracking::FrameResult r = process(3.0 + 0.1 * i, black);
    EXPECT_FALSE(r.map_restarted) << r.message;
    if (i >= 2) {
      EXPECT_EQ(r.state, tracking::TrackingState::kLost) << r.message;
    }
  }
  EXPECT_EQ(slam.mapRestarts(), 0);
  EXPECT_EQ(slam.tracker().trackingMap().numKeyframes(), run.young_keyframes);
  for (int k = 40; k < 80; ++k) {
    const tracking::FrameResult r = process(4.0 + 0.1 * k, renderView(next_room, *cam, k));
    if (r.map_restarted) {
      EXPECT_EQ(run.restarted_at, -1) << "restarted twice";
      run.restarted_at = k;
      EXPECT_TRUE(r.has_pose) << r.message;
      EXPECT_EQ(r.keyframes.size(), 2u) << "the new map's first two keyframes";
      EXPECT_NE(r.message.find("young map"), std::string::npos) << r.message;
    }
    if (!r.has_pose) continue;
    if (run.first_posed < 0) run.first_posed = k;
    run.estimate.push_back(r.T_cam_world.inverseTranslation());
    run.truth.push_back(cameraPose(k).translation());
  }
  slam.finish();
  run.restarts = slam.mapRestarts();
  run.state = slam.tracker().state();
  run.trajectory_frames = slam.trajectory().frames().size();
  run.first_trajectory_stamp =
      run.trajectory_frames > 0 ? slam.trajectory().frames().front().timestamp : -1.0;
  run.map_keyframes = slam.map().numKeyframes();
  run.tracker_keyframes = slam.tracker().trackingMap().numKeyframes();
  return run;
}

/// The worst position error of `estimate` after a Sim(3) alignment with `truth`.
double worstError(const std::vector<Eigen::Vector3d>& estimate,
                  const std::vector<Eigen::Vector3d>& truth) {
  const geometry::Sim3 S = evaluation::alignSim3(estimate, truth);
  double worst = 0.0;
  for (std::size_t i = 0; i < estimate.size(); ++i)
    worst = std::max(worst, (S * estimate[i] - truth[i]).norm());
  return worst;
}

// Uncovered in another room: a new map starts there, and the young map is discarded at that
// frame; the mapper and the loop closer follow, and the new map is built from the new keyframes.
TEST(Relocalisation, AYoungMapLostTooLongIsDiscardedWhenANewOneStarts) {
  for (const bool thread : {false, true}) {
    const YoungMapRun run =
        loseAYoungMap(thread, test::boxRoom(4.0, 2.0, 4.0, 40), test::boxRoom(4.0, 2.0, 4.0, 41));
    ASSERT_NE(run.restarted_at, -1) << "the new map did not start";
    EXPECT_LT(run.restarted_at, 50);
    EXPECT_EQ(run.restarts, 1);
    ASSERT_GE(run.estimate.size(), 30u);
    EXPECT_EQ(run.state, tracking::TrackingState::kGood);
    EXPECT_LT(worstError(run.estimate, run.truth), 0.03);
    // The mapper holds the new map only, the corrected trajectory the new map's frames only.
    EXPECT_EQ(run.map_keyframes, run.tracker_keyframes);
    EXPECT_EQ(run.trajectory_frames, run.estimate.size());
    EXPECT_GE(run.first_trajectory_stamp, 8.0);
  }
}

// Uncovered in the same room, 1 m on: the young map, kept, is found again (before the
// restart discarded it at the tenth black frame and started another map here).
TEST(Relocalisation, AYoungMapLostTooLongIsFoundAgainWhenTheCameraReturns) {
  const auto room = test::boxRoom(4.0, 2.0, 4.0, 40);
  for (const bool thread : {false, true}) {
    const YoungMapRun run = loseAYoungMap(thread, room, room);
    EXPECT_EQ(run.restarts, 0);
    EXPECT_EQ(run.restarted_at, -1);
    ASSERT_GE(run.estimate.size(), 30u) << "not found again";
    EXPECT_EQ(run.state, tracking::TrackingState::kGood);
    EXPECT_GE(run.tracker_keyframes, run.young_keyframes);
    // The frames before and after the cover, in one map: one alignment fits both parts (a new
    // map would have its own origin and scale, off by metres), to within 2 % of the ~2.7 m path.
    EXPECT_EQ(run.trajectory_frames, run.young_estimate.size() + run.estimate.size());
    std::vector<Eigen::Vector3d> estimate = run.young_estimate, truth = run.young_truth;
    estimate.insert(estimate.end(), run.estimate.begin(), run.estimate.end());
    truth.insert(truth.end(), run.truth.begin(), run.truth.end());
    std::printf("found again at frame %d; worst error %.4f m over %zu frames\n", run.first_posed,
                worstError(estimate, truth), estimate.size());
    EXPECT_LT(worstError(estimate, truth), 0.05);
    EXPECT_LE(run.first_posed, 42) << "found again late";
  }
}

// A young map lost for good (the camera never sees anything usable again) is not thrown away
// for nothing: it stays the map, and the run keeps its poses.
TEST(Relocalisation, AYoungMapLostForGoodStaysTheMap) {
  const auto room = test::boxRoom(4.0, 2.0, 4.0, 40);
  const auto cam = camera();
  system::SlamParams params;
  params.mapping_thread = false;
  params.tracker.restart_after_lost_frames = 6;
  system::SlamSystem slam(cam, params);
  int posed = 0;
  for (int k = 0; k < 30; ++k) {
    posed += slam.processFrame(0.1 * k, renderView(room, *cam, k), features::PixelEncoding::kMono8)
                 .has_pose;
  }
  ASSERT_EQ(slam.tracker().state(), tracking::TrackingState::kGood);
  ASSERT_GT(posed, 20);
  const std::size_t young_keyframes = slam.tracker().trackingMap().numKeyframes();
  // Covered, then a blank wall: rejected frames, then frames too flat to track or start from.
  const cv::Mat black = cv::Mat::zeros(kHeight, kWidth, CV_8UC1);
  cv::Mat wall(kHeight, kWidth, CV_8UC1);
  cv::randu(wall, 100, 104);  // 4 grey levels of noise: a frame, but nothing to track
  for (int i = 0; i < 40; ++i) {
    const tracking::FrameResult r =
        slam.processFrame(3.0 + 0.1 * i, i < 10 ? black : wall, features::PixelEncoding::kMono8);
    EXPECT_FALSE(r.map_restarted) << r.message;
    EXPECT_FALSE(r.has_pose) << r.message;
  }
  slam.finish();
  EXPECT_EQ(slam.mapRestarts(), 0);
  EXPECT_EQ(slam.tracker().state(), tracking::TrackingState::kLost);
  EXPECT_EQ(slam.tracker().trackingMap().numKeyframes(), young_keyframes);
  EXPECT_EQ(slam.trajectory().frames().size(), static_cast<std::size_t>(posed));
}

}  // namespace
}  // namespace scale_drift_slam::system
