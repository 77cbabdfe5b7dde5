// Invalid messages between the parts (system/message_validation.h) are refused with the reason
// before they change anything, at the mapper, the loop closer and the tracker's inbox alike; the
// real message with the same id is taken afterwards (issue 17: same-session keyframes with a NaN
// pose, a pose at 1e9, 50 000 observations or an id ahead of the tracker were taken and blocked
// the real keyframes as "already in the map").

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "../tracking/synthetic_images.h"

#include "scale_drift_slam/system/loop_closer_endpoint.h"
#include "scale_drift_slam/system/mapper_endpoint.h"
#include "scale_drift_slam/system/message_validation.h"
#include "scale_drift_slam/system/tracker_inbox.h"

namespace scale_drift_slam::system {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double focal() {
  return 500.0;
}

std::shared_ptr<const geometry::CameraModel> someCamera() {
  return test::pinholeCamera(500.0);
}

/// A keyframe as the tracker makes it: a pose, two new points it observes.
map::KeyframeMessage keyframe(map::KeyframeId id) {
  map::KeyframeMessage message;
  message.keyframe.id = id;
  message.keyframe.timestamp = 0.1 * id;
  message.keyframe.T_kf_world =
      geometry::SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-0.1 * id, 0.0, 0.0));
  for (map::PointId k = 0; k < 2; ++k) {
    const map::PointId point = 2 * id + k;
    message.new_points.push_back({point, Eigen::Vector3d(0.1 * id, 0.2 * k, 2.0), id});
    message.keyframe.observations.push_back({point, Eigen::Vector2d(0.01 * k, 0.02)});
  }
  return message;
}

mapping::MapperParams mapperParams() {
  mapping::MapperParams params;
  params.run_window_ba = false;  // the validation, not the BA, is under test
  return params;
}

/// The bad same-session keyframes of issue 17, each with the id `id`.
std::vector<std::pair<std::string, map::KeyframeMessage>> badKeyframes(map::KeyframeId id) {
  std::vector<std::pair<std::string, map::KeyframeMessage>> bad;
  bad.emplace_back("NaN pose", keyframe(id));
  bad.back().second.keyframe.T_kf_world.translation().x() = kNaN;
  bad.emplace_back("pose at 1e9", keyframe(id));
  bad.back().second.keyframe.T_kf_world.translation().z() = 1e9;
  bad.emplace_back("50 000 observations", keyframe(id));
  bad.back().second.keyframe.observations.assign(50000, {2 * id, Eigen::Vector2d(0.0, 0.0)});
  bad.emplace_back("NaN stamp", keyframe(id));
  bad.back().second.keyframe.timestamp = kNaN;
  bad.emplace_back("NaN new point", keyframe(id));
  bad.back().second.new_points[0].p_world.y() = kNaN;
  bad.emplace_back("infinite observation", keyframe(id));
  bad.back().second.keyframe.observations[1].xy.x() = std::numeric_limits<double>::infinity();
  bad.emplace_back("earlier observation in a later keyframe", keyframe(id));
  bad.back().second.earlier_observations.push_back({id + 5, 2 * id, Eigen::Vector2d::Zero()});
  return bad;
}

struct MapState {
  std::size_t keyframes, points;
  std::uint64_t version;
  Eigen::Vector3d newest_translation;
  bool operator==(const MapState& o) const {
    return keyframes == o.keyframes && points == o.points && version == o.version &&
           newest_translation == o.newest_translation;
  }
};

MapState stateOf(const map::Map& map) {
  return {map.numKeyframes(), map.numPoints(), map.version(),
          map.keyframes().rbegin()->second.T_kf_world.translation()};
}

TEST(MessageValidation, InvalidSameSessionKeyframesChangeNothingAtTheMapper) {
  MapperEndpoint mapper(mapperParams(), 7);
  for (map::KeyframeId id = 0; id < 3; ++id)
    ASSERT_TRUE(mapper.addKeyframe({1, 0, 0}, keyframe(id), focal).added);
  const MapState before = stateOf(mapper.map());
  for (const auto& [what, bad] : badKeyframes(3)) {
    const auto outcome = mapper.addKeyframe({1, 0, 0}, bad, focal);
    EXPECT_FALSE(outcome.added) << what;
    EXPECT_NE(outcome.refusal.find("keyframe 3 has"), std::string::npos)
        << what << ": " << outcome.refusal;
    EXPECT_FALSE(outcome.update.has_value()) << what;
    EXPECT_EQ(stateOf(mapper.map()), before) << what;
  }
  // The real keyframe 3 is still taken.
  const auto real = mapper.addKeyframe({1, 0, 0}, keyframe(3), focal);
  ASSERT_TRUE(real.added) << real.refusal;
  EXPECT_EQ(mapper.map().numKeyframes(), 4u);
  EXPECT_EQ(mapper.map().keyframe(3).observations.size(), 2u);
}

TEST(MessageValidation, AKeyframeIdFarAheadOfTheSessionIsRefusedAndTheRealOneTakenLater) {
  MessageLimits limits;
  limits.max_keyframe_id_gap = 10;
  MapperEndpoint mapper(mapperParams(), 7, limits);
  LoopCloserEndpoint closer(loop::LoopCloserParams{}, limits);
  for (map::KeyframeId id = 0; id < 3; ++id) {
    ASSERT_TRUE(mapper.addKeyframe({1, 0, 0}, keyframe(id), focal).added);
    ASSERT_TRUE(closer.addKeyframe({1, 0, 0}, keyframe(id), someCamera).added);
  }
  const MapState before = stateOf(mapper.map());
  for (const map::KeyframeId id : {40u, 4294967295u}) {
    map::KeyframeMessage forged = keyframe(3);  // sane content, an id far ahead
    forged.keyframe.id = id;
    const auto at_mapper = mapper.addKeyframe({1, 0, 0}, forged, focal);
    EXPECT_FALSE(at_mapper.added);
    EXPECT_NE(at_mapper.refusal.find("ahead of the newest one held (2"), std::string::npos)
        << at_mapper.refusal;
    EXPECT_EQ(stateOf(mapper.map()), before);
    const auto at_closer = closer.addKeyframe({1, 0, 0}, forged, someCamera);
    EXPECT_FALSE(at_closer.added);
    EXPECT_NE(at_closer.refusal.find("ahead"), std::string::npos) << at_closer.refusal;
    EXPECT_EQ(closer.closer()->numKeyframes(), 3u);
  }
  // Within the gap (keyframes lost on the way) ids are taken; the tracker reaches 40 later.
  for (map::KeyframeId id = 3; id <= 40; id += 2) {
    const auto outcome = mapper.addKeyframe({1, 0, 0}, keyframe(id), focal);
    ASSERT_TRUE(outcome.added) << id << ": " << outcome.refusal;
    ASSERT_TRUE(closer.addKeyframe({1, 0, 0}, keyframe(id), someCamera).added) << id;
  }
  EXPECT_TRUE(mapper.map().hasKeyframe(39));
  const auto real = mapper.addKeyframe({1, 0, 0}, keyframe(40), focal);
  EXPECT_TRUE(real.added) << real.refusal;
  EXPECT_TRUE(closer.addKeyframe({1, 0, 0}, keyframe(40), someCamera).added);
}

TEST(MessageValidation, InvalidSameSessionKeyframesChangeNothingAtTheLoopCloser) {
  LoopCloserEndpoint closer(loop::LoopCloserParams{});
  for (map::KeyframeId id = 0; id < 3; ++id)
    ASSERT_TRUE(closer.addKeyframe({1, 0, 0}, keyframe(id), someCamera).added);
  for (const auto& [what, bad] : badKeyframes(3)) {
    const auto outcome = closer.addKeyframe({1, 0, 0}, bad, someCamera);
    EXPECT_FALSE(outcome.added) << what;
    EXPECT_FALSE(outcome.refusal.empty()) << what;
    EXPECT_EQ(closer.closer()->numKeyframes(), 3u) << what;
  }
  EXPECT_TRUE(closer.addKeyframe({1, 0, 0}, keyframe(3), someCamera).added);
  EXPECT_EQ(closer.closer()->numKeyframes(), 4u);
}

TEST(MessageValidation, AnInvalidFirstKeyframeStartsNoMap) {
  MapperEndpoint mapper(mapperParams(), 7);
  map::KeyframeMessage bad = keyframe(0);
  bad.keyframe.T_kf_world.translation().y() = -1e9;
  EXPECT_FALSE(mapper.addKeyframe({1, 0, 0}, bad, focal).added);
  EXPECT_EQ(mapper.map().numKeyframes(), 0u);
  EXPECT_TRUE(mapper.addKeyframe({1, 0, 0}, keyframe(0), focal).new_map);
}

TEST(MessageValidation, ZeroOrNaNCameraMatrixIsRefused) {
  geometry::CameraCalibration camera;
  camera.fx = camera.fy = 500.0;
  camera.cx = 320.0;
  camera.cy = 240.0;
  camera.width = 640;
  camera.height = 480;
  EXPECT_EQ(cameraProblem(camera), "");
  for (const double bad : {0.0, -1.0, kNaN, std::numeric_limits<double>::infinity()}) {
    geometry::CameraCalibration broken = camera;
    broken.fx = bad;
    EXPECT_NE(cameraProblem(broken), "") << bad;
    broken = camera;
    broken.cy = bad == 0.0 ? kNaN : bad * 1e9;
    EXPECT_NE(cameraProblem(broken), "") << bad;
  }
}

TEST(MessageValidation, InvalidLoopConstraintsAreRefusedBeforeTheGraph) {
  MapperEndpoint mapper(mapperParams(), 7);
  for (map::KeyframeId id = 0; id < 3; ++id)
    ASSERT_TRUE(mapper.addKeyframe({1, 0, 0}, keyframe(id), focal).added);
  const MapState before = stateOf(mapper.map());
  loop::LoopConstraint nan_scale;
  nan_scale.current_id = 2;
  nan_scale.loop_id = 0;
  nan_scale.S_current_loop =
      geometry::Sim3(Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero(), kNaN);
  loop::LoopConstraint huge = nan_scale;
  huge.S_current_loop =
      geometry::Sim3::fromScale(Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero(), 1e9);
  loop::LoopConstraint far = nan_scale;
  far.S_current_loop =
      geometry::Sim3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.0, 1e9, 0.0), 0.0);
  loop::LoopConstraint self = far;
  self.S_current_loop = geometry::Sim3();
  self.loop_id = 2;
  for (const loop::LoopConstraint& bad : {nan_scale, huge, far, self}) {
    const auto outcome = mapper.closeLoop({1, 7, 3}, bad);
    EXPECT_FALSE(outcome.refusal.empty());
    EXPECT_FALSE(outcome.statistics.applied);
    EXPECT_FALSE(outcome.update.has_value());
    EXPECT_EQ(stateOf(mapper.map()), before);
  }
  EXPECT_TRUE(mapper.loopEdges().empty());
}

TEST(MessageValidation, InvalidMapUpdatesAreRefusedByTheLoopCloser) {
  LoopCloserEndpoint closer(loop::LoopCloserParams{});
  for (map::KeyframeId id = 0; id < 3; ++id)
    ASSERT_TRUE(closer.addKeyframe({1, 0, 0}, keyframe(id), someCamera).added);
  map::MapUpdate bad;
  bad.map_version = 1;
  bad.keyframe_poses.emplace_back(
      1, geometry::SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(kNaN, 0.0, 0.0)));
  const auto outcome = closer.applyMapUpdate({1, 7, 1}, bad);
  EXPECT_FALSE(outcome.applied);
  EXPECT_NE(outcome.refusal.find("non-finite pose for keyframe 1"), std::string::npos)
      << outcome.refusal;
  EXPECT_EQ(closer.closer()->mapVersion(), 0u);
  EXPECT_TRUE(closer.closer()->map().keyframe(1).T_kf_world.translation().allFinite());
  map::MapUpdate good = bad;
  good.keyframe_poses[0].second = keyframe(1).keyframe.T_kf_world;
  EXPECT_TRUE(closer.applyMapUpdate({1, 7, 1}, good).applied);
}

TEST(MessageValidation, InvalidRelocalisationRequestsAreAnsweredWithTheReason) {
  LoopCloserEndpoint closer(loop::LoopCloserParams{});
  ASSERT_TRUE(closer.addKeyframe({1, 0, 0}, keyframe(0), someCamera).added);
  map::RelocalisationRequest request;
  request.frame_index = 12;
  request.timestamp = kNaN;
  request.image = cv::Mat(48, 64, CV_8UC1, cv::Scalar(0));
  const auto answer = closer.relocalise({1, 0, 0}, request);
  EXPECT_FALSE(answer.message.success);
  EXPECT_EQ(answer.message.frame_index, 12u);
  EXPECT_NE(answer.message.reason.find("non-finite stamp"), std::string::npos);
  request.timestamp = 1.0;
  request.image = cv::Mat();
  EXPECT_NE(closer.relocalise({1, 0, 0}, request).message.reason.find("no image"),
            std::string::npos);
}

TEST(MessageValidation, TheTrackersInboxRefusesInvalidUpdatesAndAnswers) {
  tracking::Tracker tracker(someCamera(), tracking::TrackerParams{});
  map::CorrectedTrajectory trajectory;
  TrackerInbox inbox;
  inbox.startSession(3);
  map::MapUpdate nan_point;
  nan_point.map_version = 4;
  nan_point.point_positions.emplace_back(1, Eigen::Vector3d(0.0, kNaN, 1.0));
  map::MapUpdate huge_scale;
  huge_scale.map_version = 5;
  huge_scale.S_new_old =
      geometry::Sim3::fromScale(Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero(), 1e-9);
  // The tracker made no keyframe yet: nobody can correct one.
  map::MapUpdate unknown_keyframe;
  unknown_keyframe.map_version = 6;
  unknown_keyframe.keyframe_poses.emplace_back(0, geometry::SE3());
  for (const map::MapUpdate& bad : {nan_point, huge_scale, unknown_keyframe})
    inbox.push(Addressed<map::MapUpdate>{{3, 7, bad.map_version}, bad});
  map::RelocalisationAnswer nan_pose;
  nan_pose.success = true;
  nan_pose.T_cam_world.translation().x() = kNaN;
  inbox.push(Addressed<map::RelocalisationAnswer>{{3, 7, 1}, nan_pose});
  const TrackerInbox::Report report = inbox.drain(tracker, trajectory);
  ASSERT_EQ(report.refused.size(), 4u);
  EXPECT_NE(report.refused[0].find("non-finite position for point 1"), std::string::npos);
  EXPECT_NE(report.refused[1].find("Sim(3) of scale"), std::string::npos);
  EXPECT_NE(report.refused[2].find("keyframe 0, which the tracker never made"), std::string::npos)
      << report.refused[2];
  EXPECT_NE(report.refused[3].find("non-finite pose"), std::string::npos);
  EXPECT_FALSE(report.relocalised.has_value());
  EXPECT_EQ(tracker.trackingMap().version(), 0u);
  EXPECT_EQ(inbox.address(0).mapper_id, 0u);  // no mapper met: nothing was applied
  // A valid update of the session is still applied.
  map::MapUpdate valid;
  valid.map_version = 4;
  inbox.push(Addressed<map::MapUpdate>{{3, 7, 4}, valid});
  EXPECT_TRUE(inbox.drain(tracker, trajectory).refused.empty());
  EXPECT_EQ(tracker.trackingMap().version(), 4u);
}

TEST(MessageValidation, IdsAheadOfTheTrackerAreNamed) {
  map::MapUpdate update;
  update.keyframe_corrections.emplace_back(8, geometry::Sim3());
  EXPECT_EQ(trackerIdsProblem(update, map::KeyframeId{8}), "");
  EXPECT_NE(trackerIdsProblem(update, map::KeyframeId{7}), "");
  update.keyframe_corrections.clear();
  update.loop_links.emplace_back(2, 9);
  EXPECT_NE(trackerIdsProblem(update, map::KeyframeId{8}), "");
  map::RelocalisationAnswer answer;
  answer.success = true;
  answer.keyframe_id = 9;
  EXPECT_NE(trackerIdsProblem(answer, map::KeyframeId{8}), "");
  EXPECT_EQ(trackerIdsProblem(answer, map::KeyframeId{9}), "");
  answer.success = false;  // a failed answer names no keyframe
  EXPECT_EQ(trackerIdsProblem(answer, std::nullopt), "");
}

TEST(MessageValidation, LimitsAreValidated) {
  MessageLimits limits;
  EXPECT_NO_THROW(limits.validate());
  limits.max_scale_ratio = 1.0;
  EXPECT_THROW(limits.validate(), std::invalid_argument);
  limits = MessageLimits{};
  limits.max_observations = 0;
  EXPECT_THROW(MapperEndpoint(mapperParams(), 1, limits), std::invalid_argument);
}

}  // namespace
}  // namespace scale_drift_slam::system
