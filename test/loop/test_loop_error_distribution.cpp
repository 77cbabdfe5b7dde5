// The initial guess of the pose graph (loop/loop_error_distribution.h): it lowers chi2 on a
// drifting loop, keeps the fixed vertices, changes nothing without a loop edge, and LM reaches
// the same optimum from it as from the given poses, in fewer iterations.

#include <algorithm>
#include <cmath>
#include <map>

#include <gtest/gtest.h>

#include "scale_drift_slam/loop/loop_error_distribution.h"
#include "scale_drift_slam/loop/pose_graph.h"
#include "scale_drift_slam/sim/drifting_pose_graph.h"

namespace scale_drift_slam::loop {
namespace {

using geometry::Sim3;

/// Laps of 200 keyframes (radius 10) whose odometry halves the map scale per lap, with noise.
sim::DriftingPoseGraph driftingLoop(int laps = 1, int loops = 1, int keyframes_per_lap = 200) {
  sim::DriftingPoseGraphOptions options;
  options.keyframes_per_lap = keyframes_per_lap;
  options.laps = laps;
  options.loops = loops;
  options.log_scale_drift_per_keyframe = std::log(0.5) / 200;
  options.log_scale_noise = 1e-3;
  options.rotation_noise = 1e-3;
  options.translation_noise = 1e-3;
  options.seed = 7;
  return sim::makeDriftingPoseGraph(options);
}

std::map<map::KeyframeId, Sim3> asMap(const PoseGraph& graph, const std::vector<Sim3>& poses) {
  std::map<map::KeyframeId, Sim3> result;
  std::size_t index = 0;
  for (const auto& entry : graph.vertices()) {
    result.emplace(entry.first, poses.at(index++));
  }
  return result;
}

double maxCentreDistance(const std::map<map::KeyframeId, Sim3>& a,
                         const std::map<map::KeyframeId, Sim3>& b) {
  double distance = 0.0;
  for (const auto& [id, S] : a) {
    distance = std::max(distance, (cameraCentre(S) - cameraCentre(b.at(id))).norm());
  }
  return distance;
}

TEST(LoopErrorDistribution, LowersChi2AndKeepsFixedVertices) {
  const sim::DriftingPoseGraph simulated = driftingLoop();
  const PoseGraph& graph = simulated.graph;
  for (PoseGraphMode mode : {PoseGraphMode::kSim3, PoseGraphMode::kSE3}) {
    for (int passes : {1, 3}) {
      const LoopErrorDistribution guess = distributeLoopErrors(graph, mode, passes);
      ASSERT_EQ(guess.S_kf_world.size(), graph.vertices().size()) << toString(mode);
      EXPECT_EQ(guess.loops, 1);
      EXPECT_NEAR(guess.given_chi2, graph.chi2(mode), 1e-9 * guess.given_chi2);
      EXPECT_NEAR(guess.chi2, graph.chi2(mode, asMap(graph, guess.S_kf_world)),
                  1e-9 * guess.given_chi2);
      // Measured: one pass takes chi2 from ~200 (Sim(3)) down by more than 10x; three passes
      // land within a few percent of the optimum.
      EXPECT_LT(guess.chi2, 0.1 * guess.given_chi2) << toString(mode) << " passes " << passes;
      const Sim3& fixed = graph.vertices().at(0).S_kf_world;
      EXPECT_LT((guess.S_kf_world.front().matrix() - fixed.matrix()).norm(), 1e-15);
      if (mode == PoseGraphMode::kSE3) {
        for (const Sim3& S : guess.S_kf_world) {
          EXPECT_EQ(S.logScale(), 0.0);
        }
      }
    }
  }
}

TEST(LoopErrorDistribution, NothingToDoWithoutALoopEdge) {
  PoseGraph graph;
  graph.addVertex(0, Sim3(), true);
  graph.addVertex(1, Sim3::exp((Sim3::Tangent() << 0.1, 0, 0, 0.2, 1, 0, 0).finished()));
  PoseGraphEdge edge;
  edge.from = 1;
  edge.to = 0;
  edge.S_from_to = Sim3::exp(Sim3::Tangent::Constant(0.05));
  graph.addEdge(edge);
  const LoopErrorDistribution guess = distributeLoopErrors(graph, PoseGraphMode::kSim3, 3);
  EXPECT_TRUE(guess.S_kf_world.empty());
  EXPECT_EQ(guess.loops, 0);
  EXPECT_EQ(guess.chi2, guess.given_chi2);
  EXPECT_THROW(distributeLoopErrors(graph, PoseGraphMode::kSim3, 0), std::invalid_argument);
  PoseGraphOptions bad;
  bad.loop_error_passes = -1;
  EXPECT_THROW(graph.optimize(bad), std::invalid_argument);
}

TEST(LoopErrorDistribution, SameOptimumInFewerIterations) {
  // One loop (measured: LM takes 1 (Sim(3)) / 2 (SE(3)) iterations from the guess instead of 5),
  // and three laps with eight overlapping loop edges and co-visibility edges, where the guess
  // would cost more than it saves and is skipped (LM starts from the given poses).
  for (const auto& [laps, loops] : {std::pair<int, int>{1, 1}, {3, 8}}) {
    const sim::DriftingPoseGraph simulated = driftingLoop(laps, loops);
    for (PoseGraphMode mode : {PoseGraphMode::kSim3, PoseGraphMode::kSE3}) {
      PoseGraphOptions from_guess;
      from_guess.mode = mode;
      PoseGraphOptions from_given = from_guess;
      from_given.loop_error_passes = 0;
      const PoseGraphResult a = simulated.graph.optimize(from_guess);
      const PoseGraphResult b = simulated.graph.optimize(from_given);
      const std::string name = toString(mode) + ", laps " + std::to_string(laps);
      EXPECT_TRUE(a.converged) << name << ": " << a.termination;
      EXPECT_NEAR(a.final_chi2, b.final_chi2, 1e-8 * b.final_chi2) << name;
      // Circle radius 10: both runs stop within 1e-4 of each other (tolerance 1e-10 on chi2).
      EXPECT_LT(maxCentreDistance(a.S_kf_world, b.S_kf_world), 1e-4) << name;
      EXPECT_LE(a.guess_chi2, a.initial_chi2) << name;
      EXPECT_NEAR(a.initial_chi2, b.initial_chi2, 1e-9 * b.initial_chi2) << name;
      EXPECT_EQ(b.guess_loops, 0) << name;
      if (laps == 1) {
        EXPECT_EQ(a.guess_loops, 1) << name;
        EXPECT_LT(a.guess_chi2, 1e-2 * a.initial_chi2) << name;
        EXPECT_LT(a.iterations, b.iterations) << name;
      } else {
        EXPECT_EQ(a.guess_loops, 0) << name;
        EXPECT_EQ(a.iterations, b.iterations) << name;
      }
    }
  }
}

TEST(LoopErrorDistribution, OverlappingLoopsAreSolvedTogether) {
  // Two laps of 100 keyframes, two loop edges from the second lap back to the first whose paths
  // share half their edges. Solved together, two passes reach the optimum's chi2 (measured:
  // within 0.03 %; each loop corrected on its own, the last one overwriting the shared edges,
  // stayed 12x above it in Sim(3)).
  const sim::DriftingPoseGraph simulated = driftingLoop(2, 2, 100);
  const PoseGraph& graph = simulated.graph;
  ASSERT_EQ(graph.numEdges(EdgeKind::kLoop), 2u);
  for (PoseGraphMode mode : {PoseGraphMode::kSim3, PoseGraphMode::kSE3}) {
    PoseGraphOptions tight;
    tight.mode = mode;
    tight.loop_error_passes = 0;
    tight.function_tolerance = 1e-12;
    const PoseGraphResult optimum = graph.optimize(tight);
    const LoopErrorDistribution guess = distributeLoopErrors(graph, mode, 2);
    EXPECT_EQ(guess.loops, 2) << toString(mode);
    EXPECT_LT(guess.chi2, 1.01 * optimum.final_chi2) << toString(mode);
    EXPECT_GT(guess.given_chi2, 100 * optimum.final_chi2) << toString(mode);
  }
}

}  // namespace
}  // namespace scale_drift_slam::loop
