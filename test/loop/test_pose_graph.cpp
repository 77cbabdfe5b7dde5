// The pose-graph estimator on simulated graphs with known truth (sim/drifting_pose_graph.h): a
// loop with injected scale drift is recovered by Sim(3) and not by SE(3); several loops at once;
// fixed vertices stay fixed; analytic and autodiff derivatives reach the same optimum; bad input
// is refused with a reason.

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "scale_drift_slam/loop/pose_graph.h"
#include "scale_drift_slam/sim/drifting_pose_graph.h"

namespace scale_drift_slam::loop {
namespace {

using geometry::SE3;
using geometry::Sim3;

/// One lap of 200 keyframes on a circle of radius 10 whose odometry shrinks the map to half its
/// scale by the end of the lap, with small rotation, translation and scale noise on top.
sim::DriftingPoseGraphOptions driftingLoop() {
  sim::DriftingPoseGraphOptions options;
  options.keyframes_per_lap = 200;
  options.log_scale_drift_per_keyframe = std::log(0.5) / 200;
  options.log_scale_noise = 1e-3;
  options.rotation_noise = 1e-3;
  options.translation_noise = 1e-3;
  options.seed = 7;
  return options;
}

PoseGraphOptions modeOptions(PoseGraphMode mode) {
  PoseGraphOptions options;
  options.mode = mode;
  return options;
}

TEST(PoseGraph, Sim3RecoversInjectedScaleDriftAndSE3DoesNot) {
  const sim::DriftingPoseGraph simulated = sim::makeDriftingPoseGraph(driftingLoop());
  const double rmse_before = [&] {
    std::map<map::KeyframeId, Sim3> poses;
    for (const auto& [id, vertex] : simulated.graph.vertices()) {
      poses[id] = vertex.S_kf_world;
    }
    return sim::centreRmse(poses, simulated.centres_true);
  }();
  const PoseGraphResult sim3 = simulated.graph.optimize(modeOptions(PoseGraphMode::kSim3));
  const PoseGraphResult se3 = simulated.graph.optimize(modeOptions(PoseGraphMode::kSE3));
  const double rmse_sim3 = sim::centreRmse(sim3.S_kf_world, simulated.centres_true);
  const double rmse_se3 = sim::centreRmse(se3.S_kf_world, simulated.centres_true);
  // Before: the drifted circle is 3.7 m off (rms). Sim(3) returns to the truth within 10 cm (1 %
  // of the radius; measured 5.8 cm: identity information trades the scale steps against the
  // other residuals and the odometry noise stays); SE(3) closes the loop but keeps the wrong
  // scale: 4.5 m off, worse than before.
  EXPECT_GT(rmse_before, 3.0);
  EXPECT_LT(rmse_sim3, 0.1);
  EXPECT_GT(rmse_se3, 3.0);
  EXPECT_TRUE(sim3.converged) << sim3.termination;
  EXPECT_TRUE(se3.converged) << se3.termination;
  // The Sim(3) vertices carry the injected scale: the last keyframe's local scale is recovered
  // within 1 % (the truth V_i has scale s_i).
  const double s_true = simulated.S_kf_world_true.back().scale();
  EXPECT_NEAR(sim3.S_kf_world.rbegin()->second.scale() / s_true, 1.0, 0.01) << s_true;
  for (const auto& entry : se3.S_kf_world) {
    EXPECT_EQ(entry.second.logScale(), 0.0);
  }
  // The reported chi2 is the graph's own measure of the returned poses.
  EXPECT_NEAR(sim3.final_chi2, simulated.graph.chi2(PoseGraphMode::kSim3, sim3.S_kf_world), 1e-9);
  EXPECT_NEAR(se3.final_chi2, simulated.graph.chi2(PoseGraphMode::kSE3, se3.S_kf_world), 1e-9);
  EXPECT_LT(sim3.final_chi2, 1e-3 * sim3.initial_chi2);
}

TEST(PoseGraph, SeveralLoopsAtOnce) {
  sim::DriftingPoseGraphOptions options = driftingLoop();
  options.keyframes_per_lap = 100;
  options.laps = 3;
  options.loops = 8;
  options.covisibility_neighbours = 2;
  options.log_scale_drift_per_keyframe = std::log(0.4) / 300;
  const sim::DriftingPoseGraph simulated = sim::makeDriftingPoseGraph(options);
  EXPECT_EQ(simulated.graph.numEdges(EdgeKind::kLoop), 8u);
  const PoseGraphResult sim3 = simulated.graph.optimize(modeOptions(PoseGraphMode::kSim3));
  const PoseGraphResult se3 = simulated.graph.optimize(modeOptions(PoseGraphMode::kSE3));
  const double rmse_sim3 = sim::centreRmse(sim3.S_kf_world, simulated.centres_true);
  const double rmse_se3 = sim::centreRmse(se3.S_kf_world, simulated.centres_true);
  // Measured: Sim(3) 0.29 m, SE(3) 7.2 m (after at most 100 iterations: the SE(3) graph
  // converges slowly, it cannot reconcile the loops).
  EXPECT_LT(rmse_sim3, 0.4);
  EXPECT_GT(rmse_se3, 10 * rmse_sim3);
  EXPECT_TRUE(sim3.converged) << sim3.termination;
  // Every loop edge is closed by the Sim(3) solution.
  for (const PoseGraphEdge& edge : simulated.graph.edges()) {
    if (edge.kind != EdgeKind::kLoop) {
      continue;
    }
    const Sim3::Tangent r = sim3EdgeResidual(edge.S_from_to, sim3.S_kf_world.at(edge.from),
                                             sim3.S_kf_world.at(edge.to));
    EXPECT_LT(r.norm(), 0.02) << edge.from << " -> " << edge.to;
  }
}

TEST(PoseGraph, FixedVerticesStayFixed) {
  sim::DriftingPoseGraph simulated = sim::makeDriftingPoseGraph(driftingLoop());
  simulated.graph.setFixed(100);
  for (PoseGraphMode mode : {PoseGraphMode::kSim3, PoseGraphMode::kSE3}) {
    const PoseGraphResult result = simulated.graph.optimize(modeOptions(mode));
    for (const map::KeyframeId id : {0u, 100u}) {
      const Sim3& before = simulated.graph.vertices().at(id).S_kf_world;
      const Sim3& after = result.S_kf_world.at(id);
      EXPECT_LT((after.matrix() - before.matrix()).norm(), 1e-15) << id;
    }
    // Keyframes 1..99 sit between two fixed vertices on edges measured from their own poses: they
    // have nothing to correct. The loop error is spread over 101..199.
    EXPECT_LT(
        (result.S_kf_world.at(50).matrix() - simulated.graph.vertices().at(50).S_kf_world.matrix())
            .norm(),
        1e-9);
    EXPECT_GT((result.S_kf_world.at(150).matrix() -
               simulated.graph.vertices().at(150).S_kf_world.matrix())
                  .norm(),
              0.1);
  }
}

TEST(PoseGraph, AnalyticAndAutoDiffReachTheSameOptimum) {
  sim::DriftingPoseGraphOptions options = driftingLoop();
  options.keyframes_per_lap = 60;
  const sim::DriftingPoseGraph simulated = sim::makeDriftingPoseGraph(options);
  for (PoseGraphMode mode : {PoseGraphMode::kSim3, PoseGraphMode::kSE3}) {
    PoseGraphOptions analytic = modeOptions(mode), autodiff = modeOptions(mode);
    autodiff.jacobians = PoseGraphJacobians::kAutoDiff;
    const PoseGraphResult a = simulated.graph.optimize(analytic);
    const PoseGraphResult b = simulated.graph.optimize(autodiff);
    EXPECT_NEAR(a.final_chi2, b.final_chi2, 1e-10 + 1e-8 * a.final_chi2);
    for (const auto& [id, S] : a.S_kf_world) {
      EXPECT_LT((S.matrix() - b.S_kf_world.at(id).matrix()).norm(), 1e-6) << id;
    }
  }
}

TEST(PoseGraph, RefusesBadInput) {
  PoseGraph graph;
  graph.addVertex(0, Sim3(), true);
  graph.addVertex(1, Sim3());
  EXPECT_THROW(graph.addVertex(1, Sim3()), std::invalid_argument);  // duplicate
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(
      graph.addVertex(2, Sim3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(nan, 0, 0), 0)),
      std::invalid_argument);
  PoseGraphEdge edge;
  edge.from = 0;
  edge.to = 5;  // missing vertex
  EXPECT_THROW(graph.addEdge(edge), std::invalid_argument);
  edge.to = 0;  // a vertex to itself
  EXPECT_THROW(graph.addEdge(edge), std::invalid_argument);
  edge.to = 1;
  edge.S_from_to = Sim3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, nan, 0), 0);
  EXPECT_THROW(graph.addEdge(edge), std::invalid_argument);  // NaN measurement
  edge.S_from_to = Sim3::fromScale(Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero(), -2.0);
  EXPECT_THROW(graph.addEdge(edge), std::invalid_argument);  // non-positive scale
  EXPECT_THROW(similarityWithScale(SE3(), 0.0), std::invalid_argument);
  EXPECT_THROW(similarityWithScale(SE3(), -0.4), std::invalid_argument);
  EXPECT_THROW(similarityWithScale(SE3(), nan), std::invalid_argument);
  edge.S_from_to = Sim3();
  edge.information(3, 3) = -1.0;
  EXPECT_THROW(graph.addEdge(edge), std::invalid_argument);  // indefinite information
  EXPECT_THROW(graph.setFixed(9), std::invalid_argument);
  EXPECT_EQ(graph.edges().size(), 0u);

  // Vertex 1 is connected to nothing: its pose would be undetermined.
  EXPECT_THROW(graph.optimize(PoseGraphOptions()), std::invalid_argument);
  edge.information = Matrix7d::Identity();
  graph.addEdge(edge);
  graph.setFixed(0, false);  // no fixed vertex: the gauge is free
  EXPECT_THROW(graph.optimize(PoseGraphOptions()), std::invalid_argument);
  graph.setFixed(0);
  PoseGraphOptions bad;
  bad.max_iterations = 0;
  EXPECT_THROW(graph.optimize(bad), std::invalid_argument);
  bad = PoseGraphOptions();
  bad.function_tolerance = nan;
  EXPECT_THROW(graph.optimize(bad), std::invalid_argument);
  EXPECT_NO_THROW(graph.optimize(PoseGraphOptions()));
  EXPECT_THROW(parsePoseGraphMode("sim2"), std::invalid_argument);
  EXPECT_THROW(parsePoseGraphJacobians("numeric"), std::invalid_argument);
}

}  // namespace
}  // namespace scale_drift_slam::loop
