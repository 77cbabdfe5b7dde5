// The Keble College experiment in the core on the real map: the graph is the authors' one and
// the outcome is the paper's (Figure 2); the tool test checks the files and the same figures.

#include <gtest/gtest.h>

#include "scale_drift_slam/sim/keble_experiment.h"

namespace scale_drift_slam::sim {
namespace {

TEST(KebleExperiment, Sim3ClosesTheLoopWithTheRightScaleAndSE3DoesNot) {
  const io::KebleMap keble =
      io::loadKebleMap(std::string(SDS_TEST_DATA_DIR) + "/keble_college/keble_college.txt");
  const KebleExperimentResult result = runKebleExperiment(keble, KebleExperimentOptions());
  EXPECT_EQ(result.vertices, 740u);
  EXPECT_EQ(result.consecutive_edges, 739u);
  EXPECT_EQ(result.loop_edges, 1u);
  EXPECT_GT(result.loop_gap_before, 1.5);
  EXPECT_LT(result.se3.loop_gap, 0.1);
  EXPECT_NEAR(result.se3.path_length, result.path_length_before, 0.3);
  EXPECT_LT(result.sim3.loop_gap, 0.01);
  EXPECT_GT(result.sim3.path_length, 16.0);
  EXPECT_LT(result.sim3.path_length, 19.5);
  EXPECT_NEAR(result.sim3.last_keyframe_scale, keble.loop_scale, 0.02);
  // Keyframes before the loop keyframe are not in the graph and keep their poses.
  for (std::size_t k = 0; k <= keble.loop_keyframe; ++k) {
    EXPECT_LT((result.sim3.centres[k] - result.centres_before[k]).norm(), 1e-12) << k;
  }
  EXPECT_LT(result.sim3.structure.after.median, result.reprojection_before.median);
}

TEST(KebleExperiment, RefusesBadOptions) {
  KebleExperimentOptions options;
  options.min_shared_points = -3;
  EXPECT_THROW(options.validate(), std::invalid_argument);
  options = KebleExperimentOptions();
  options.structure.huber_width_px = -1.0;
  EXPECT_THROW(options.validate(), std::invalid_argument);
}

}  // namespace
}  // namespace scale_drift_slam::sim
