// Map points with a wrong depth get observations (tracker.keyframe_refused_matches_px): on real
// images about half the matches a pose refuses are map points whose depth is wrong, matched
// again and again on their own texture while their reprojection walks away; a keyframe that
// leaves them out leaves them wrong for good. Here points of a tracked room are pushed along the
// ray of the keyframe that made them (what a bad triangulation does), and the next keyframe
// carries their refused matches at the pixels of their true positions.

#include <algorithm>
#include <cstdio>
#include <map>

#include <gtest/gtest.h>

#include "scale_drift_slam/tracking/tracker.h"
#include "synthetic_images.h"

namespace scale_drift_slam::tracking {
namespace {

constexpr int kWidth = 640, kHeight = 480;

struct Carried {
  int pushed = 0;       ///< Points given a wrong depth.
  int observed = 0;     ///< ...observed by the next keyframe...
  int nearer_true = 0;  ///< ...nearer the pixel of their position before than of the pushed one.
  std::vector<double> true_px;  ///< Distance from the pixel of the position before.
};

/// Tracks 30 frames of the sweep, pushes every point of the newest keyframe that it made 15 %
/// further along its ray, then tracks on until the next keyframe.
Carried pushAndTrack(double refused_px) {
  const auto room = test::boxRoom(4.0, 2.0, 4.0, 40);
  const auto camera = test::pinholeCamera(450.0);
  TrackerParams params;
  params.keyframe_refused_matches_px = refused_px;
  Tracker tracker(camera, params);
  const auto process = [&](int k) {
    const cv::Mat image =
        test::renderPlanes(room, camera->K(), test::sweepPose(k).inverse(), kWidth, kHeight);
    return tracker.processFrame(0.1 * k, image, features::PixelEncoding::kMono8);
  };
  int k = 0;
  for (; k < 30; ++k)
    process(k);
  EXPECT_EQ(tracker.state(), TrackingState::kGood);
  const TrackingMap& map = tracker.trackingMap();
  const TrackedKeyframe& newest = map.keyframes().rbegin()->second;
  const Eigen::Vector3d centre = newest.T_kf_world.inverseTranslation();
  map::MapUpdate update;
  update.map_version = 1;
  std::map<map::PointId, std::pair<Eigen::Vector3d, Eigen::Vector3d>> before;  // and pushed
  for (const map::PointId id : newest.points) {
    if (!map.hasPoint(id) || map.point(id).reference_keyframe != newest.id) continue;
    const Eigen::Vector3d& p = map.point(id).p_world;
    const Eigen::Vector3d pushed = centre + 1.15 * (p - centre);
    before[id] = {p, pushed};
    update.point_positions.emplace_back(id, pushed);
  }
  tracker.applyMapUpdate(update);
  Carried carried;
  carried.pushed = static_cast<int>(before.size());
  for (++k; k < 60; ++k) {
    const FrameResult r = process(k);
    if (r.keyframes.empty()) continue;
    const map::Keyframe& keyframe = r.keyframes.front().keyframe;
    for (const map::Observation& o : keyframe.observations) {
      const auto it = before.find(o.point_id);
      if (it == before.end()) continue;
      const auto px_from = [&](const Eigen::Vector3d& p_world) {
        const Eigen::Vector3d p_cam = keyframe.T_kf_world * p_world;
        return 450.0 * (o.xyd() - p_cam.head<2>() / p_cam.z()).norm();
      };
      const double to_true = px_from(it->second.first);
      ++carried.observed;
      carried.nearer_true += to_true < px_from(it->second.second);
      carried.true_px.push_back(to_true);
    }
    break;
  }
  return carried;
}

TEST(RefusedMatches, AKeyframeObservesPointsWithAWrongDepthWhereTheyReallyAre) {
  const Carried with = pushAndTrack(10.0);
  const Carried without = pushAndTrack(0.0);
  std::vector<double> px = with.true_px;
  std::sort(px.begin(), px.end());
  const double median = px.empty() ? 1e9 : px[px.size() / 2];
  std::printf(
      "%d points pushed 15 %% along their ray: observed by the next keyframe %d, %d nearer "
      "their true pixel than the pushed one (median %.2f px from it, worst %.2f px); "
      "without the refused matches %d\n",
      with.pushed, with.observed, with.nearer_true, median, px.empty() ? 0.0 : px.back(),
      without.observed);
  ASSERT_GE(with.pushed, 30);
  EXPECT_GE(with.observed, with.pushed / 4);
  EXPECT_EQ(with.nearer_true, with.observed);
  EXPECT_LT(median, 1.0);
  EXPECT_LT(without.observed, with.observed / 3);
}

}  // namespace
}  // namespace scale_drift_slam::tracking
