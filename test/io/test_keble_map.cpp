// The Keble College map reader on the real file (the counts and values its README states) and on
// broken copies, each of which must be refused with the file, the line and the reason.

#include <cmath>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "scale_drift_slam/io/keble_map.h"
#include "scale_drift_slam/mapping/structure_only_ba.h"

namespace scale_drift_slam::io {
namespace {

const std::string kKeble = std::string(SDS_TEST_DATA_DIR) + "/keble_college/keble_college.txt";

TEST(KebleMap, ReadsThePapersMap) {
  const KebleMap keble = loadKebleMap(kKeble);
  EXPECT_EQ(keble.map.numKeyframes(), 765u);  // + the current camera = 766 poses
  EXPECT_EQ(keble.current_id, 765u);
  EXPECT_EQ(keble.map.numPoints(), 11885u);
  EXPECT_EQ(keble.map.numObservations(), 84820u);
  EXPECT_EQ(keble.loop_keyframe, 25u);
  EXPECT_DOUBLE_EQ(keble.loop_scale, 0.370729);
  EXPECT_LT((keble.map.keyframe(0).T_kf_world.matrix() - Eigen::Matrix4d::Identity()).norm(),
            1e-12);
  // Pose 1 of the file: t = (0.0606025, 0.00065658, -0.0103205).
  EXPECT_LT((keble.map.keyframe(1).T_kf_world.translation() -
             Eigen::Vector3d(0.0606025, 0.00065658, -0.0103205))
                .norm(),
            1e-12);
  // Observation "0, 0 : 244 24": x = (244 - 162) / 195, y = (24 - 125) / -195.
  const map::Observation& first = keble.map.keyframe(0).observations.front();
  EXPECT_EQ(first.point_id, 0u);
  // Held in single precision (map::Observation): to its last bit.
  EXPECT_EQ(first.xy.x(), static_cast<float>(82.0 / 195.0));
  EXPECT_EQ(first.xy.y(), static_cast<float>(101.0 / 195.0));
  // Point 0 is seen by keyframes 0 and 1: it moves with the newest one.
  EXPECT_EQ(keble.map.point(0).reference_keyframe, 1u);
  // The README: median reprojection error about 1.1 px, 90th percentile about 6-8 px.
  const mapping::ReprojectionStats stats =
      mapping::reprojectionStats(keble.map, keble.camera.focalLength());
  EXPECT_NEAR(stats.median, 1.17, 0.1);
  EXPECT_GT(stats.p90, 5.0);
  EXPECT_LT(stats.p90, 9.0);
}

/// A copy of the real file with line `line_number` (1-based) replaced by `text`.
std::string brokenCopy(const std::string& name, int line_number, const std::string& text) {
  std::ifstream in(kKeble);
  std::string path = std::string(SDS_TEST_OUTPUT_DIR) + "/" + name;
  std::ofstream out(path);
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    out << (n == line_number ? text : line) << '\n';
  }
  return path;
}

void expectError(const std::string& path, const std::string& fragment) {
  try {
    loadKebleMap(path);
    ADD_FAILURE() << "no error for " << path;
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

TEST(KebleMap, RefusesBrokenFiles) {
  // Line numbers in the real file: 1 "Poses", 2-4 pose 0, 3066 "Scale", 3067 the scale,
  // 3068 "LoopId", 3069 the id, 3070 "Points", 3071 point 0, 14956 "Obs", 14957 "0, 0 : 244 24".
  expectError(std::string(SDS_TEST_OUTPUT_DIR) + "/no_such_keble.txt", "cannot open");
  expectError(brokenCopy("keble_bad_number.txt", 3, "0 1 0 zero"), "line 3");
  expectError(brokenCopy("keble_not_rotation.txt", 2, "2 0 0 0"), "not a rotation");
  expectError(brokenCopy("keble_short_pose.txt", 4, "Scale"), "fewer than 3 rows");
  expectError(brokenCopy("keble_negative_scale.txt", 3067, "-0.37"), "line 3067");
  expectError(brokenCopy("keble_zero_scale.txt", 3067, "0"), "must be > 0");
  expectError(brokenCopy("keble_no_scale.txt", 3066, "Scalar"), "line 3066");
  expectError(brokenCopy("keble_nan_point.txt", 3071, "nan 0 1"), "line 3071");
  expectError(brokenCopy("keble_loop_id.txt", 3069, "765"), "leaves no keyframes");
  expectError(brokenCopy("keble_unknown_point.txt", 14957, "99999, 0 : 244 24"), "unknown point");
  expectError(brokenCopy("keble_current_obs.txt", 14957, "0, 765 : 244 24"), "not a keyframe");
  expectError(brokenCopy("keble_bad_obs.txt", 14957, "0 0 244"), "line 14957");
}

}  // namespace
}  // namespace scale_drift_slam::io
