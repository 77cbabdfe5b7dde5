// TUM trajectories survive a save/load round trip; EuRoC csv files are read with the right
// quaternion order and nanosecond stamps; malformed files fail with the line number.

#include <fstream>

#include <gtest/gtest.h>

#include "scale_drift_slam/io/trajectory_io.h"

namespace scale_drift_slam::io {
namespace {

std::string writeFile(const std::string& name, const std::string& text) {
  const std::string path = std::string(SDS_TEST_OUTPUT_DIR) + "/" + name;
  std::ofstream(path) << text;
  return path;
}

TEST(TrajectoryIo, TumRoundTripIsExact) {
  std::vector<StampedPose> poses;
  for (int i = 0; i < 5; ++i) {
    geometry::SE3::Tangent xi;
    xi << 0.1 * i, -0.2, 0.3 * i, 1.0 + i, 2.5, -0.125 * i;
    poses.push_back({1403636579.763555527 + 0.05 * i, geometry::SE3::exp(xi)});
  }
  const std::string path = std::string(SDS_TEST_OUTPUT_DIR) + "/roundtrip.tum";
  saveTumTrajectory(path, poses, "test");
  const auto loaded = loadTrajectory(path);
  ASSERT_EQ(loaded.size(), poses.size());
  for (size_t i = 0; i < poses.size(); ++i) {
    EXPECT_NEAR(loaded[i].timestamp, poses[i].timestamp, 1e-9);
    EXPECT_LT((loaded[i].T_world_cam.matrix() - poses[i].T_world_cam.matrix()).norm(), 1e-14);
  }
}

TEST(TrajectoryIo, ReadsEurocCsv) {
  const auto poses = loadTrajectory(writeFile(
      "euroc.csv",
      "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], "
      "q_RS_z []\n1403636580838555648,4.688,-1.786,0.783,0.5,-0.5,0.5,-0.5,0,0,0\n"));
  ASSERT_EQ(poses.size(), 1u);
  EXPECT_NEAR(poses[0].timestamp, 1403636580.838555648, 1e-6);
  EXPECT_EQ(poses[0].T_world_cam.translation().x(), 4.688);
  EXPECT_NEAR(poses[0].T_world_cam.rotation().w(), 0.5, 1e-15);
  EXPECT_NEAR(poses[0].T_world_cam.rotation().x(), -0.5, 1e-15);
}

TEST(TrajectoryIo, MalformedFilesFailWithTheLine) {
  const std::string path = writeFile("bad.tum", "# comment\n1 2 3 4 0 0 0 1\n2 3 4 nope\n");
  try {
    loadTrajectory(path);
    FAIL() << "accepted a malformed line";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("line 3"), std::string::npos) << e.what();
  }
  EXPECT_THROW(loadTrajectory(writeFile("zero_q.tum", "1 2 3 4 0 0 0 0\n")), std::runtime_error);
  EXPECT_THROW(loadTrajectory("/nonexistent.tum"), std::runtime_error);
}

// Issue 17: outputs are sorted, repeated stamps dropped (the first pose kept) and counted.
TEST(TrajectoryIo, SortsAndDropsRepeatedStamps) {
  auto at = [](double t, double x) {
    return StampedPose{t, geometry::SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(x, 0, 0))};
  };
  std::vector<StampedPose> poses = {at(3, 0), at(1, 1), at(2, 2), at(2, 3), at(1, 4)};
  std::size_t reordered = 0;
  EXPECT_EQ(sortAndDropRepeatedStamps(&poses, &reordered), 2u);
  EXPECT_EQ(reordered, 2u);  // 3 -> 1 and 2 -> 1
  ASSERT_EQ(poses.size(), 3u);
  EXPECT_EQ(poses[0].timestamp, 1.0);
  EXPECT_EQ(poses[0].T_world_cam.translation().x(), 1.0);  // the first pose of stamp 1
  EXPECT_EQ(poses[1].T_world_cam.translation().x(), 2.0);
  EXPECT_EQ(poses[2].timestamp, 3.0);
  std::vector<StampedPose> sorted = {at(1, 0), at(2, 0)};
  EXPECT_EQ(sortAndDropRepeatedStamps(&sorted), 0u);
  EXPECT_EQ(sorted.size(), 2u);
}

}  // namespace
}  // namespace scale_drift_slam::io
