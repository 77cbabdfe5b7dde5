// tracker.keyframe_worker: a keyframe's triangulation runs in a worker thread while the next frame
// is awaited. Everything must come out as without the worker (the same poses, the same keyframes
// with the same points and observations); only each keyframe is reported one frame later, or by
// finishKeyframes() at the end, and a map update between frames finishes it first.

#include <optional>
#include <vector>

#include <gtest/gtest.h>

#include "scale_drift_slam/tracking/tracker.h"
#include "synthetic_images.h"

namespace scale_drift_slam::tracking {
namespace {

constexpr int kWidth = 640, kHeight = 480;
constexpr int kFrames = 60;
constexpr int kUpdateAfter = 30;  ///< A map update follows the first keyframe from this frame.

struct SweepRun {
  std::vector<std::optional<geometry::SE3>> poses;  ///< Per frame.
  std::vector<map::KeyframeMessage> keyframes;      ///< In the order reported.
  std::vector<int> reported_at;                     ///< The frame that reported each (-1: end).
  std::vector<int> dropped_at;                      ///< The frame that made each.
};

SweepRun trackSweep(bool worker) {
  const auto room = test::boxRoom(4.0, 2.0, 4.0, 40);
  const auto camera = test::pinholeCamera(450.0);
  TrackerParams params;
  params.keyframe_worker = worker;
  Tracker tracker(camera, params);
  SweepRun run;
  const auto keep = [&run](std::vector<map::KeyframeMessage> keyframes, int frame) {
    for (map::KeyframeMessage& message : keyframes) {
      run.keyframes.push_back(std::move(message));
      run.reported_at.push_back(frame);
    }
  };
  std::optional<map::KeyframeId> newest;
  bool updated = false;
  for (int k = 0; k < kFrames; ++k) {
    if (!updated && k > kUpdateAfter && run.dropped_at.back() == k - 1) {
      // The mapper moved the points that the newest keyframes see and that it knows of: not
      // those made at the newest keyframe, which it has not received yet. That keyframe is
      // still pending with the worker: it is finished before the update and rides with it.
      EXPECT_EQ(tracker.keyframePending(), worker);
      map::MapUpdate update;
      update.map_version = 1;
      const TrackingMap& map = tracker.trackingMap();
      const map::KeyframeId pending_id = map.keyframes().rbegin()->first;
      int moved_keyframes = 0;
      for (auto it = map.keyframes().rbegin(); it != map.keyframes().rend() && moved_keyframes < 2;
           ++it, ++moved_keyframes) {
        for (const map::PointId id : it->second.points) {
          if (map.hasPoint(id) && map.point(id).reference_keyframe < pending_id)
            update.point_positions.emplace_back(id, 1.001 * map.point(id).p_world);
        }
      }
      tracker.applyMapUpdate(update);
      EXPECT_FALSE(tracker.keyframePending());
      updated = true;
    }
    const cv::Mat image =
        test::renderPlanes(room, camera->K(), test::sweepPose(2 * k).inverse(), kWidth, kHeight);
    FrameResult result = tracker.processFrame(0.1 * k, image, features::PixelEncoding::kMono8);
    run.poses.push_back(result.has_pose ? std::optional(result.T_cam_world) : std::nullopt);
    keep(std::move(result.keyframes), k);
    // The keyframes made at this frame: the map's newest ids above the last one seen.
    for (const auto& [id, keyframe] : tracker.trackingMap().keyframes()) {
      if (!newest || id > *newest) {
        run.dropped_at.push_back(k);
        newest = id;
      }
    }
  }
  keep(tracker.finishKeyframes(), -1);
  EXPECT_TRUE(updated);
  EXPECT_FALSE(tracker.keyframePending());
  return run;
}

TEST(KeyframeWorker, SameResultsAsWithoutItEachKeyframeReportedOneFrameLater) {
  const SweepRun inline_run = trackSweep(false);
  const SweepRun worker_run = trackSweep(true);

  ASSERT_EQ(inline_run.poses.size(), worker_run.poses.size());
  int tracked = 0;
  for (std::size_t k = 0; k < inline_run.poses.size(); ++k) {
    ASSERT_EQ(inline_run.poses[k].has_value(), worker_run.poses[k].has_value()) << "frame " << k;
    if (!inline_run.poses[k]) continue;
    ++tracked;
    EXPECT_LT((inline_run.poses[k]->matrix() - worker_run.poses[k]->matrix()).norm(), 1e-12)
        << "frame " << k;
  }
  EXPECT_GE(tracked, kFrames - 5);

  ASSERT_EQ(inline_run.keyframes.size(), worker_run.keyframes.size());
  ASSERT_GE(inline_run.keyframes.size(), 5u);
  int with_triangulated_points = 0;
  for (std::size_t i = 0; i < inline_run.keyframes.size(); ++i) {
    const map::KeyframeMessage& a = inline_run.keyframes[i];
    const map::KeyframeMessage& b = worker_run.keyframes[i];
    EXPECT_EQ(a.keyframe.id, b.keyframe.id);
    EXPECT_EQ(a.map_version, b.map_version);
    EXPECT_LT((a.keyframe.T_kf_world.matrix() - b.keyframe.T_kf_world.matrix()).norm(), 1e-12);
    ASSERT_EQ(a.keyframe.observations.size(), b.keyframe.observations.size()) << "keyframe " << i;
    for (std::size_t o = 0; o < a.keyframe.observations.size(); ++o) {
      EXPECT_EQ(a.keyframe.observations[o].point_id, b.keyframe.observations[o].point_id);
      EXPECT_EQ(a.keyframe.observations[o].xy, b.keyframe.observations[o].xy);
    }
    ASSERT_EQ(a.new_points.size(), b.new_points.size()) << "keyframe " << i;
    for (std::size_t p = 0; p < a.new_points.size(); ++p) {
      EXPECT_EQ(a.new_points[p].id, b.new_points[p].id);
      EXPECT_EQ(a.new_points[p].p_world, b.new_points[p].p_world);
    }
    EXPECT_EQ(a.earlier_observations.size(), b.earlier_observations.size());
    with_triangulated_points += !a.earlier_observations.empty();
  }
  EXPECT_GE(with_triangulated_points, 3);

  // Without the worker each keyframe is reported by the frame that made it; with it by the next
  // frame (the last one, if made at the last frame, by finishKeyframes()), except the two of the
  // map's initialisation, which come together.
  ASSERT_EQ(inline_run.dropped_at.size(), inline_run.keyframes.size());
  for (std::size_t i = 0; i < inline_run.keyframes.size(); ++i) {
    const int made = inline_run.dropped_at[i];
    EXPECT_EQ(inline_run.reported_at[i], made) << "keyframe " << i;
    const bool initial = i < 2;
    const int expected = initial ? made : (made + 1 < kFrames ? made + 1 : -1);
    EXPECT_EQ(worker_run.reported_at[i], expected) << "keyframe " << i;
  }
}

}  // namespace
}  // namespace scale_drift_slam::tracking
