// Building the pose graph from a map and correcting the map with its solution. The key check: a
// map drifted in scale by the simulation (sim/drifting_pose_graph.h), corrected with the true
// similarities, gets back the true points exactly; and the full chain (build, solve, correct)
// moves points close to the truth.

#include <random>

#include <gtest/gtest.h>

#include "scale_drift_slam/loop/map_correction.h"
#include "scale_drift_slam/loop/pose_graph_builder.h"
#include "scale_drift_slam/sim/drifting_pose_graph.h"

namespace scale_drift_slam::loop {
namespace {

using geometry::SE3;
using geometry::Sim3;

/// The drifted keyframe map of a simulated loop: keyframes at the estimated poses, and for each
/// keyframe k points seen by k and k+1 (reference keyframe k) placed where the drifted
/// estimate puts them: p_est = E_k^-1 (V_k p_true), so that they look right from keyframe k.
struct DriftedMap {
  sim::DriftingPoseGraph simulated;
  map::Map map;
  std::map<map::PointId, Eigen::Vector3d> truth;
};

DriftedMap makeDriftedMap(int keyframes, double final_scale) {
  sim::DriftingPoseGraphOptions options;
  options.keyframes_per_lap = keyframes;
  options.log_scale_drift_per_keyframe = std::log(final_scale) / keyframes;
  DriftedMap drifted{sim::makeDriftingPoseGraph(options), {}, {}};
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  map::PointId next_id = 0;
  for (int k = 0; k < keyframes; ++k) {
    const SE3& T_true = drifted.simulated.T_kf_world_true[k];
    for (int n = 0; n < 5; ++n) {
      const Eigen::Vector3d p_cam(uniform(rng), uniform(rng), 4.0 + uniform(rng));
      const Eigen::Vector3d p_true = T_true.inverse() * p_cam;
      const Eigen::Vector3d p_est = drifted.simulated.T_kf_world_estimate[k].inverse() *
                                    (drifted.simulated.S_kf_world_true[k] * p_true);
      drifted.map.addPoint({next_id, p_est, static_cast<map::KeyframeId>(k), {}});
      drifted.truth[next_id++] = p_true;
    }
  }
  for (int k = 0; k < keyframes; ++k) {
    map::Keyframe keyframe;
    keyframe.id = k;
    keyframe.T_kf_world = drifted.simulated.T_kf_world_estimate[k];
    for (int back = 0; back <= 1 && back <= k; ++back) {  // own points and the previous ones
      for (int n = 0; n < 5; ++n) {
        keyframe.observations.push_back(
            {map::PointId(5 * (k - back) + n), Eigen::Vector2d::Zero()});
      }
    }
    drifted.map.addKeyframe(keyframe);
  }
  return drifted;
}

double pointRmse(const map::Map& map, const std::map<map::PointId, Eigen::Vector3d>& truth) {
  double sum = 0.0;
  for (const auto& [id, p] : truth) {
    sum += (map.point(id).p_world - p).squaredNorm();
  }
  return std::sqrt(sum / truth.size());
}

TEST(MapCorrection, TrueSimilaritiesRestoreTheTruePoints) {
  DriftedMap drifted = makeDriftedMap(80, 0.5);
  EXPECT_GT(pointRmse(drifted.map, drifted.truth), 1.0);
  std::map<map::KeyframeId, Sim3> truth;
  for (std::size_t k = 0; k < drifted.simulated.S_kf_world_true.size(); ++k) {
    truth[k] = drifted.simulated.S_kf_world_true[k];
  }
  const MapCorrectionStats stats = applyPoseGraphCorrection(drifted.map, truth);
  EXPECT_EQ(stats.keyframes_corrected, 80u);
  EXPECT_EQ(stats.points_moved, 400u);
  EXPECT_LT(pointRmse(drifted.map, drifted.truth), 1e-9);
  for (std::size_t k = 0; k < 80; ++k) {  // rotation kept, translation t/s: the true pose
    const SE3 expected = drifted.simulated.T_kf_world_true[k];
    EXPECT_LT((drifted.map.keyframe(k).T_kf_world.matrix() - expected.matrix()).norm(), 1e-9);
  }
}

TEST(MapCorrection, BuildSolveCorrectBringsPointsBack) {
  DriftedMap drifted = makeDriftedMap(80, 0.5);
  const Sim3 loop_measurement =
      drifted.simulated.S_kf_world_true[79] * drifted.simulated.S_kf_world_true[0].inverse();
  PoseGraphEdge loop_edge{79, 0, loop_measurement, Matrix7d::Identity(), EdgeKind::kLoop};
  PoseGraphBuilderOptions builder;
  builder.min_shared_points = 5;  // consecutive keyframes share 5 points: no extra edges
  const PoseGraph graph = buildPoseGraph(drifted.map, {}, {loop_edge}, {0}, builder);
  EXPECT_EQ(graph.vertices().size(), 80u);
  EXPECT_EQ(graph.numEdges(EdgeKind::kConsecutive), 79u);
  EXPECT_EQ(graph.numEdges(EdgeKind::kCovisibility), 0u);
  // The consecutive edges are measured from the map itself: only the loop edge has a residual.
  const Sim3::Tangent loop_residual = sim3EdgeResidual(
      loop_measurement, graph.vertices().at(79).S_kf_world, graph.vertices().at(0).S_kf_world);
  EXPECT_NEAR(graph.chi2(PoseGraphMode::kSim3), loop_residual.squaredNorm(), 1e-12);
  const double before = pointRmse(drifted.map, drifted.truth);
  const PoseGraphResult result = graph.optimize(PoseGraphOptions());
  applyPoseGraphCorrection(drifted.map, result.S_kf_world);
  // The solved similarities are not exactly the truth (identity information spreads the scale
  // steps), so neither are the points; measured: 4.9 m before, 0.19 m after (3.9 %).
  EXPECT_LT(pointRmse(drifted.map, drifted.truth), 0.06 * before);
}

TEST(PoseGraphBuilder, EdgesFromTheMap) {
  DriftedMap drifted = makeDriftedMap(10, 0.9);
  // Keyframes k and k+2 share no point, k and k+1 share 5.
  PoseGraphBuilderOptions builder;
  builder.consecutive_edges = false;
  builder.min_shared_points = 5;
  const PoseGraph covisibility = buildPoseGraph(drifted.map, {2, 3, 4, 6}, {}, {2}, builder);
  EXPECT_EQ(covisibility.numEdges(EdgeKind::kCovisibility), 2u);  // 2-3, 3-4
  for (const PoseGraphEdge& edge : covisibility.edges()) {
    EXPECT_GT(edge.from, edge.to);  // newer -> older
    EXPECT_LT(sim3EdgeResidual(edge.S_from_to, covisibility.vertices().at(edge.from).S_kf_world,
                               covisibility.vertices().at(edge.to).S_kf_world)
                  .norm(),
              1e-12);
  }
  builder.consecutive_edges = true;
  const PoseGraph both = buildPoseGraph(drifted.map, {2, 3, 4, 6}, {}, {2}, builder);
  EXPECT_EQ(both.numEdges(EdgeKind::kConsecutive), 3u);   // 2-3, 3-4, 4-6
  EXPECT_EQ(both.numEdges(EdgeKind::kCovisibility), 0u);  // already consecutive
  EXPECT_TRUE(both.vertices().at(2).fixed);
  EXPECT_EQ(both.numFixed(), 1u);
}

TEST(PoseGraphBuilder, RefusesBadInput) {
  DriftedMap drifted = makeDriftedMap(10, 0.9);
  const PoseGraphBuilderOptions builder;
  EXPECT_THROW(buildPoseGraph(drifted.map, {1, 2, 42}, {}, {1}, builder), std::invalid_argument);
  EXPECT_THROW(buildPoseGraph(drifted.map, {1, 2}, {}, {5}, builder), std::invalid_argument);
  PoseGraphEdge outside{9, 1, Sim3(), Matrix7d::Identity(), EdgeKind::kLoop};
  EXPECT_THROW(buildPoseGraph(drifted.map, {1, 2}, {outside}, {1}, builder), std::invalid_argument);
  PoseGraphBuilderOptions negative;
  negative.min_shared_points = -1;
  EXPECT_THROW(buildPoseGraph(drifted.map, {}, {}, {0}, negative), std::invalid_argument);
}

TEST(MapCorrection, RefusesBadInputAndLeavesTheMapUntouched) {
  DriftedMap drifted = makeDriftedMap(10, 0.9);
  const Eigen::Vector3d p0 = drifted.map.point(0).p_world;
  std::map<map::KeyframeId, Sim3> poses = {{0, Sim3()}, {77, Sim3()}};
  EXPECT_THROW(applyPoseGraphCorrection(drifted.map, poses), std::invalid_argument);
  poses = {{0, Sim3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(std::nan(""), 0, 0), 0.0)}};
  EXPECT_THROW(applyPoseGraphCorrection(drifted.map, poses), std::invalid_argument);
  EXPECT_EQ(drifted.map.point(0).p_world, p0);
  // Keyframes without a corrected pose keep theirs; their points stay.
  const SE3 T5 = drifted.map.keyframe(5).T_kf_world;
  const Eigen::Vector3d p25 = drifted.map.point(25).p_world;  // reference keyframe 5
  applyPoseGraphCorrection(drifted.map, {{0, Sim3::exp(Sim3::Tangent::Constant(0.1))}});
  EXPECT_EQ(drifted.map.keyframe(5).T_kf_world.matrix(), T5.matrix());
  EXPECT_EQ(drifted.map.point(25).p_world, p25);
  EXPECT_NE(drifted.map.point(0).p_world, p0);
}

/// The map of makeDriftedMap corrected with C_k = `before` for keyframes < `split` and `after` for
/// the others (C_k = S_k_new^-1 T_k_old, so S_k_new = T_k_old C_k^-1); returns the corrections.
std::vector<std::pair<map::KeyframeId, Sim3>> correctInTwoParts(map::Map& map, int split,
                                                                const Sim3& before,
                                                                const Sim3& after) {
  std::vector<std::pair<map::KeyframeId, Sim3>> corrections;
  std::map<map::KeyframeId, Sim3> S_new;
  for (const auto& [id, keyframe] : map.keyframes()) {
    const Sim3& C = static_cast<int>(id) < split ? before : after;
    corrections.emplace_back(id, C);
    S_new.emplace(id, Sim3(keyframe.T_kf_world) * C.inverse());
  }
  applyPoseGraphCorrection(map, S_new);
  return corrections;
}

TEST(DisturbedPoints, OnlyPointsSeenAcrossANonSmoothCorrection) {
  // Keyframe k observes its own points (5k .. 5k+4, reference k) and those of k-1.
  const Sim3 C_a =
      Sim3::exp((Sim3::Tangent() << 0.02, -0.01, 0.03, 0.1, 0.5, -0.2, 0.3).finished());
  const Sim3 C_b = Sim3::exp((Sim3::Tangent() << -0.01, 0.02, 0.0, 0.3, -0.4, 0.1, 0.2).finished());
  // One similarity for the whole map moves it rigidly (up to scale): nothing is disturbed.
  DriftedMap whole = makeDriftedMap(10, 0.9);
  const auto same = correctInTwoParts(whole.map, 0, C_a, C_a);
  EXPECT_TRUE(pointsDisturbedByCorrection(whole.map, same, 500.0, 0.01).empty());
  // Keyframes 0-4 by one similarity and 5-9 by another: the points of keyframe 4, which keyframe
  // 5 sees too, are disturbed, and only those.
  DriftedMap split = makeDriftedMap(10, 0.9);
  const auto two = correctInTwoParts(split.map, 5, C_a, C_b);
  EXPECT_EQ(pointsDisturbedByCorrection(split.map, two, 500.0, 0.5),
            (std::vector<map::PointId>{20, 21, 22, 23, 24}));
  // A tiny threshold: still those five (elsewhere both keyframes moved alike, up to rounding).
  EXPECT_EQ(pointsDisturbedByCorrection(split.map, two, 500.0, 1e-6).size(), 5u);
}

TEST(DisturbedPoints, ThresholdInPixels) {
  // Two keyframes at the origin looking down +z, a point 10 m ahead anchored to keyframe 0. The
  // correction of keyframe 1 differs from keyframe 0's by 1 cm sideways: in keyframe 1 the point
  // is seen 0.01 / 10 normalised units = 0.5 px (f = 500) away from where it was seen before.
  map::Map map;
  map.addPoint({7, Eigen::Vector3d(0.0, 0.0, 10.0), 0, {}});
  for (map::KeyframeId id : {0u, 1u}) {
    map::Keyframe keyframe;
    keyframe.id = id;
    keyframe.observations.push_back({7, Eigen::Vector2d::Zero()});
    map.addKeyframe(keyframe);
  }
  const std::vector<std::pair<map::KeyframeId, Sim3>> corrections = {
      {0, Sim3()}, {1, Sim3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.01, 0, 0), 0.0)}};
  EXPECT_EQ(pointsDisturbedByCorrection(map, corrections, 500.0, 0.45),
            std::vector<map::PointId>{7});
  EXPECT_TRUE(pointsDisturbedByCorrection(map, corrections, 500.0, 0.55).empty());
  // Keyframe 1 without a correction counts as not moved: the same 0.5 px, the other way round.
  EXPECT_EQ(pointsDisturbedByCorrection(map, {{0, corrections[1].second}}, 500.0, 0.45),
            std::vector<map::PointId>{7});
  // Behind the camera after the correction: disturbed whatever the threshold.
  const std::vector<std::pair<map::KeyframeId, Sim3>> behind = {
      {0, Sim3()}, {1, Sim3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, -20.0), 0.0)}};
  EXPECT_EQ(pointsDisturbedByCorrection(map, behind, 500.0, 1e6), std::vector<map::PointId>{7});
  EXPECT_THROW(pointsDisturbedByCorrection(map, corrections, 0.0, 0.5), std::invalid_argument);
  EXPECT_THROW(pointsDisturbedByCorrection(map, corrections, 500.0, -1.0), std::invalid_argument);
}

}  // namespace
}  // namespace scale_drift_slam::loop
