// The one session / map-version protocol between the tracker, the mapper and the loop closer
// (system/envelope.h and the endpoints), as SlamSystem and the ROS nodes both use it: a restart of
// each part (tracker: a new session; mapper: a new id counting from 0; loop closer: a fresh one
// joining a running session), stale and out-of-order messages, and forged ones that must change
// nothing.

#include <limits>
#include <stdexcept>

#include <gtest/gtest.h>

#include "../tracking/synthetic_images.h"

#include "scale_drift_slam/system/loop_closer_endpoint.h"
#include "scale_drift_slam/system/mapper_endpoint.h"
#include "scale_drift_slam/system/tracker_inbox.h"

namespace scale_drift_slam::system {
namespace {

std::shared_ptr<const geometry::CameraModel> someCamera() {
  return test::pinholeCamera(500.0);
}

double focal() {
  return 500.0;
}

map::KeyframeMessage keyframe(map::KeyframeId id) {
  map::KeyframeMessage message;
  message.keyframe.id = id;
  message.keyframe.timestamp = 0.1 * id;
  message.keyframe.T_kf_world =
      geometry::SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-0.1 * id, 0.0, 0.0));
  return message;
}

mapping::MapperParams mapperParams() {
  mapping::MapperParams params;
  params.run_window_ba = false;  // the protocol, not the BA, is under test
  return params;
}

loop::LoopConstraint constraintBetween(map::KeyframeId current, map::KeyframeId loop) {
  loop::LoopConstraint constraint;
  constraint.current_id = current;
  constraint.loop_id = loop;
  return constraint;
}

TEST(SessionProtocol, ANewTrackerSessionStartsANewMapAndRetiresEverythingOfTheOld) {
  MapperEndpoint mapper(mapperParams(), 7);
  for (map::KeyframeId id = 0; id < 3; ++id) {
    const auto outcome = mapper.addKeyframe({1, 0, 0}, keyframe(id), focal);
    ASSERT_TRUE(outcome.added) << outcome.refusal;
    EXPECT_EQ(outcome.new_map, id == 0);
    ASSERT_TRUE(outcome.update.has_value());
    EXPECT_EQ(outcome.update->from.session, 1u);
    EXPECT_EQ(outcome.update->from.mapper_id, 7u);
  }
  // The tracker restarted (session 2): its keyframe 0 starts a new map.
  const auto restart = mapper.addKeyframe({2, 0, 0}, keyframe(0), focal);
  ASSERT_TRUE(restart.added) << restart.refusal;
  EXPECT_TRUE(restart.new_map);
  EXPECT_EQ(mapper.map().numKeyframes(), 1u);
  EXPECT_EQ(mapper.session(), 2u);
  // A loop found in the old map arrives late: dropped, the new map untouched.
  const auto late = mapper.closeLoop({1, 7, 3}, constraintBetween(2, 0));
  EXPECT_TRUE(late.stale);
  EXPECT_FALSE(late.update.has_value());
  // The tracker's inbox drops updates of the old session once it started the new one.
  tracking::Tracker tracker(someCamera(), tracking::TrackerParams{});
  map::CorrectedTrajectory trajectory;
  TrackerInbox inbox;
  inbox.startSession(1);
  map::MapUpdate old_update;
  old_update.map_version = 3;
  inbox.push(Addressed<map::MapUpdate>{{1, 7, 3}, old_update});
  inbox.startSession(2);
  inbox.push(Addressed<map::MapUpdate>{{1, 7, 4}, old_update});
  inbox.drain(tracker, trajectory);
  EXPECT_EQ(tracker.trackingMap().version(), 0u);
  EXPECT_EQ(inbox.address(0).session, 2u);

  // The loop closer follows the same rule.
  LoopCloserEndpoint closer(loop::LoopCloserParams{});
  ASSERT_TRUE(closer.addKeyframe({1, 0, 0}, keyframe(0), someCamera).added);
  ASSERT_TRUE(closer.addKeyframe({1, 0, 0}, keyframe(1), someCamera).added);
  const auto new_session = closer.addKeyframe({2, 0, 0}, keyframe(0), someCamera);
  ASSERT_TRUE(new_session.added);
  EXPECT_TRUE(new_session.new_session);
  EXPECT_EQ(closer.closer()->numKeyframes(), 1u);
  map::MapUpdate update;
  update.map_version = 9;
  EXPECT_FALSE(closer.applyMapUpdate({1, 7, 9}, update).applied);  // built from the old map
}

TEST(SessionProtocol, ARestartedMapperIsFollowedAboveTheVersionsAlreadyApplied) {
  MapperEndpoint mapper(mapperParams(), 7);
  LoopCloserEndpoint closer(loop::LoopCloserParams{});
  tracking::Tracker tracker(someCamera(), tracking::TrackerParams{});
  map::CorrectedTrajectory trajectory;
  TrackerInbox inbox;
  inbox.startSession(1);
  for (map::KeyframeId id = 0; id < 4; ++id) {
    const auto outcome = mapper.addKeyframe(inbox.address(0), keyframe(id), focal);
    ASSERT_TRUE(outcome.added) << outcome.refusal;
    inbox.push(*outcome.update);
    closer.addKeyframe(inbox.address(0), keyframe(id), someCamera);
    closer.applyMapUpdate(outcome.update->from, outcome.update->message);
  }
  inbox.drain(tracker, trajectory);
  const std::uint64_t before = tracker.trackingMap().version();
  ASSERT_GT(before, 0u);
  EXPECT_EQ(inbox.address(before).mapper_id, 7u);
  EXPECT_EQ(inbox.address(before).map_version, before);

  // The mapping node restarts: a new id, versions from the start again, an empty map that the
  // next keyframe of the running session begins (any id: it holds no map to replace).
  mapper.reset(9);
  const auto first = mapper.addKeyframe(inbox.address(before), keyframe(4), focal);
  ASSERT_TRUE(first.added) << first.refusal;
  EXPECT_TRUE(first.new_map);
  EXPECT_EQ(first.update->from.mapper_id, 9u);
  EXPECT_LT(first.update->from.map_version, before);
  inbox.push(*first.update);
  const TrackerInbox::Report report = inbox.drain(tracker, trajectory);
  EXPECT_TRUE(report.new_mapper);
  EXPECT_EQ(tracker.trackingMap().version(), before + 1);  // continues above, not below
  // What the tracker sends now is addressed in the new mapper's numbering...
  const Envelope address = inbox.address(before + 1);
  EXPECT_EQ(address.mapper_id, 9u);
  EXPECT_EQ(address.map_version, first.update->from.map_version);
  // ...and a late update of the retired mapper is dropped.
  map::MapUpdate late;
  late.map_version = before + 5;
  inbox.push(Addressed<map::MapUpdate>{{1, 7, before + 5}, late});
  inbox.drain(tracker, trajectory);
  EXPECT_EQ(tracker.trackingMap().version(), before + 1);

  // The loop closer keeps its map and follows the new mapper.
  const std::size_t kept = closer.closer()->numKeyframes();
  const auto followed = closer.applyMapUpdate(first.update->from, first.update->message);
  EXPECT_TRUE(followed.applied);
  EXPECT_TRUE(followed.new_mapper);
  EXPECT_EQ(closer.closer()->numKeyframes(), kept);
  EXPECT_GT(closer.closer()->mapVersion(), 0u);
}

TEST(SessionProtocol, ARestartedLoopCloserJoinsTheRunningSession) {
  MapperEndpoint mapper(mapperParams(), 7);
  for (map::KeyframeId id = 0; id < 6; ++id)
    mapper.addKeyframe({3, 0, 0}, keyframe(id), focal);
  // A fresh loop closer meets the session at keyframe 6: it has no map to lose, so it joins.
  LoopCloserEndpoint closer(loop::LoopCloserParams{});
  map::RelocalisationRequest request;
  request.frame_index = 40;
  const auto before_join = closer.relocalise({3, 7, 5}, request);
  EXPECT_FALSE(before_join.message.success);
  EXPECT_EQ(before_join.from.session, 3u);  // the tracker of session 3 hears the failure
  const auto joined = closer.addKeyframe({3, 7, 5}, keyframe(6), someCamera);
  ASSERT_TRUE(joined.added) << joined.refusal;
  EXPECT_TRUE(joined.new_session);
  EXPECT_EQ(closer.session(), 3u);
  // Its constraints carry the session: the mapper takes them up (and refuses a loop to a
  // keyframe it does not hold, with the reason, instead of dropping it as stale).
  const auto loop = mapper.closeLoop({closer.session(), 7, 5}, constraintBetween(5, 42));
  EXPECT_FALSE(loop.stale);
  EXPECT_FALSE(loop.statistics.applied);
  EXPECT_FALSE(loop.statistics.reason.empty());
}

TEST(SessionProtocol, DuplicateAndOutOfOrderMessagesChangeNothing) {
  MapperEndpoint mapper(mapperParams(), 7);
  ASSERT_TRUE(mapper.addKeyframe({1, 0, 0}, keyframe(0), focal).added);
  ASSERT_TRUE(mapper.addKeyframe({1, 0, 0}, keyframe(1), focal).added);
  const auto duplicate = mapper.addKeyframe({1, 0, 0}, keyframe(1), focal);
  EXPECT_FALSE(duplicate.added);
  EXPECT_NE(duplicate.refusal.find("already in the map"), std::string::npos);
  EXPECT_EQ(mapper.map().numKeyframes(), 2u);

  tracking::Tracker tracker(someCamera(), tracking::TrackerParams{});
  map::CorrectedTrajectory trajectory;
  TrackerInbox inbox;
  inbox.startSession(1);
  for (std::uint64_t version : {4u, 6u, 5u}) {  // 5 overtaken by 6
    map::MapUpdate update;
    update.map_version = version;
    inbox.push(Addressed<map::MapUpdate>{{1, 7, version}, update});
  }
  inbox.drain(tracker, trajectory);
  EXPECT_EQ(tracker.trackingMap().version(), 6u);
}

TEST(SessionProtocol, ForgedMessagesChangeNothing) {
  MapperEndpoint mapper(mapperParams(), 7);
  LoopCloserEndpoint closer(loop::LoopCloserParams{});
  for (map::KeyframeId id = 0; id < 3; ++id) {
    ASSERT_TRUE(mapper.addKeyframe({1, 0, 0}, keyframe(id), focal).added);
    ASSERT_TRUE(closer.addKeyframe({1, 0, 0}, keyframe(id), someCamera).added);
  }
  // A keyframe of a foreign session that cannot begin a map (rostopic pub of
  // {session: 42, id: 4294967295}).
  const map::KeyframeId far_ahead = std::numeric_limits<map::KeyframeId>::max();
  const auto forged = mapper.addKeyframe({42, 0, 0}, keyframe(far_ahead), focal);
  EXPECT_FALSE(forged.added);
  EXPECT_FALSE(closer.addKeyframe({42, 0, 0}, keyframe(far_ahead), someCamera).added);
  // Keyframe 0 of a foreign session whose camera is unusable: refused before the map goes.
  const auto no_camera = []() -> double { throw std::invalid_argument("fx is 0"); };
  const auto bad_camera = mapper.addKeyframe({42, 0, 0}, keyframe(0), no_camera);
  EXPECT_FALSE(bad_camera.added);
  EXPECT_NE(bad_camera.refusal.find("fx is 0"), std::string::npos);
  const auto nan_focal = mapper.addKeyframe(
      {42, 0, 0}, keyframe(0), [] { return std::numeric_limits<double>::quiet_NaN(); });
  EXPECT_FALSE(nan_focal.added);
  const auto null_camera = closer.addKeyframe(
      {42, 0, 0}, keyframe(0), [] { return std::shared_ptr<const geometry::CameraModel>(); });
  EXPECT_FALSE(null_camera.added);
  // A keyframe of the session with a non-finite pose.
  map::KeyframeMessage nan_pose = keyframe(3);
  nan_pose.keyframe.T_kf_world =
      geometry::SE3(Eigen::Quaterniond::Identity(),
                    Eigen::Vector3d(std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0));
  EXPECT_FALSE(mapper.addKeyframe({1, 0, 0}, nan_pose, focal).added);
  EXPECT_FALSE(closer.addKeyframe({1, 0, 0}, nan_pose, someCamera).added);
  // A loop constraint of a foreign session.
  EXPECT_TRUE(mapper.closeLoop({42, 7, 0}, constraintBetween(2, 0)).stale);
  // Nothing changed.
  EXPECT_EQ(mapper.session(), 1u);
  EXPECT_EQ(mapper.map().numKeyframes(), 3u);
  EXPECT_EQ(closer.session(), 1u);
  EXPECT_EQ(closer.closer()->numKeyframes(), 3u);
}

}  // namespace
}  // namespace scale_drift_slam::system
