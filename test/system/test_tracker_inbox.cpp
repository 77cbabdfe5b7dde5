// The tracker's inbox (SlamSystem and the tracking node alike): map updates reach the tracker
// between frames only for its session, in version order, across a mapper restart (a new epoch
// above the tracker's version, the retired mapper dropped); loop corrections move the trajectory
// once; relocalisation answers of the session are handed to the tracker (which refuses them when
// it asked nothing) and failures are reported.

#include <gtest/gtest.h>

#include "../tracking/synthetic_images.h"

#include "scale_drift_slam/system/tracker_inbox.h"

namespace scale_drift_slam::system {
namespace {

std::shared_ptr<const geometry::CameraModel> someCamera() {
  return test::pinholeCamera(500.0);
}

Addressed<map::MapUpdate> updateMsg(std::uint32_t session, std::uint32_t mapper,
                                    std::uint64_t version,
                                    std::optional<geometry::Sim3> S = std::nullopt) {
  map::MapUpdate update;
  update.map_version = version;
  update.S_new_old = S;
  return {Envelope{session, mapper, version}, update};
}

Addressed<map::RelocalisationAnswer> answerMsg(std::uint32_t session,
                                               const map::RelocalisationAnswer& answer) {
  return {Envelope{session, 0, 0}, answer};
}

struct Fixture {
  Fixture() { inbox.startSession(5); }
  tracking::Tracker tracker{someCamera(), tracking::TrackerParams{}};
  map::CorrectedTrajectory trajectory;
  TrackerInbox inbox;
  TrackerInbox::Report drain() { return inbox.drain(tracker, trajectory); }
  std::uint64_t version() const { return tracker.trackingMap().version(); }
  std::uint32_t mapperId() const { return inbox.address(0).mapper_id; }
  std::uint64_t toMapper(std::uint64_t version) const { return inbox.address(version).map_version; }
};

TEST(TrackerInbox, UpdatesOfTheSessionInVersionOrderAcrossMapperRestarts) {
  Fixture f;
  f.inbox.push(updateMsg(9, 7, 300));  // built from another session's keyframes
  EXPECT_FALSE(f.drain().new_mapper);
  EXPECT_EQ(f.version(), 0u);
  EXPECT_EQ(f.mapperId(), 0u);
  f.inbox.push(updateMsg(5, 7, 300));
  f.inbox.push(updateMsg(5, 7, 310));
  f.inbox.push(updateMsg(5, 7, 305));  // overtaken: stale
  EXPECT_FALSE(f.drain().new_mapper);  // the first mapper is no restart
  EXPECT_EQ(f.version(), 310u);
  EXPECT_EQ(f.mapperId(), 7u);
  EXPECT_EQ(f.toMapper(310), 310u);
  // The mapping node restarted: its versions count from 1 again.
  f.inbox.push(updateMsg(5, 9, 1));
  EXPECT_TRUE(f.drain().new_mapper);
  EXPECT_EQ(f.version(), 311u);
  EXPECT_EQ(f.mapperId(), 9u);
  EXPECT_EQ(f.toMapper(311), 1u);
  f.inbox.push(updateMsg(5, 7, 320));  // a late update of the retired mapper
  f.inbox.push(updateMsg(5, 9, 4));
  f.drain();
  EXPECT_EQ(f.version(), 314u);
  // A new session forgets the mappers and what was queued.
  f.inbox.push(updateMsg(5, 9, 5));
  f.inbox.startSession(6);
  f.drain();
  EXPECT_EQ(f.version(), 314u);
  EXPECT_EQ(f.mapperId(), 0u);
  EXPECT_EQ(f.inbox.address(314).session, 6u);
}

TEST(TrackerInbox, LoopCorrectionsMoveTheTrajectoryOnce) {
  Fixture f;
  f.trajectory.add(1.0, geometry::SE3(), std::nullopt);
  const geometry::Sim3 S(
      geometry::SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.0, 0.0, 1.0)));
  f.inbox.push(updateMsg(5, 7, 20, S));
  f.inbox.push(updateMsg(5, 7, 19, S));  // stale: neither the tracker nor the trajectory moves
  f.drain();
  EXPECT_EQ(f.version(), 20u);
  EXPECT_NEAR(
      (f.trajectory.frames()[0].T_cam_world.inverseTranslation() - Eigen::Vector3d(0.0, 0.0, 1.0))
          .norm(),
      0.0, 1e-12);
}

TEST(TrackerInbox, AnswersOfTheSessionReachTheTracker) {
  Fixture f;
  map::RelocalisationAnswer failed;
  failed.frame_index = 12;
  failed.reason = "no keyframe looks like this frame";
  f.inbox.push(answerMsg(6, failed));
  EXPECT_EQ(f.drain().relocalisation_failure, "");  // another session's
  f.inbox.push(answerMsg(5, failed));
  EXPECT_EQ(f.drain().relocalisation_failure, "no keyframe looks like this frame");

  map::RelocalisationAnswer found;  // the tracker asked nothing: it does not take it
  found.frame_index = 12;
  found.success = true;
  found.points = {{1, {10.0, 20.0}, {0.1, 0.2}}};
  f.inbox.push(answerMsg(5, found));
  const TrackerInbox::Report report = f.drain();
  EXPECT_FALSE(report.relocalised.has_value());
  EXPECT_EQ(report.relocalisation_failure, "");
}

}  // namespace
}  // namespace scale_drift_slam::system
