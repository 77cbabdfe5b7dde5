// Loop correction on a real map (issue 18, "each loop correction <= 300 ms"): replays one loop
// correction (Mapper::closeLoop) on a map saved just before the loop was found, with the loop
// constraint the SLAM measured, and reports the time of each step (thread CPU) and what the
// correction gives: the keyframes' ATE against the ground truth (Sim(3)-aligned) and the
// reprojection errors of the whole map after the structure-only BA, for the default parameters,
// other thresholds of the structure-only BA and the earlier parameters (the structure-only BA
// over every point, LM damping 1e-6), and the pose graph alone with other solver settings against
// a fully converged solution. Measures, asserts nothing.
//
// Usage: bench_loop_correction OUT.json [MAP SUMMARY.json [GROUNDTRUTH]]
//   MAP          a map file saved before the loop (run_sequence --no-loop-closure --max-frames N
//                --save-map MAP, N the frame of the loop's current keyframe; doc/benchmarks.md,
//                "Loop correction time")
//   SUMMARY.json run_sequence's summary of a run that closed the loop: its first loop's
//                current_keyframe, loop_keyframe and S_current_loop
//   GROUNDTRUTH  TUM ground truth of the sequence (for the keyframes' ATE)
// Without a map it prints how to make one and exits 0.

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench_report.h"
#include "scale_drift_slam/common/stopwatch.h"
#include "scale_drift_slam/evaluation/trajectory_evaluation.h"
#include "scale_drift_slam/io/map_file.h"
#include "scale_drift_slam/io/trajectory_io.h"
#include "scale_drift_slam/loop/pose_graph_builder.h"
#include "scale_drift_slam/mapping/mapper.h"

namespace {

namespace sds = scale_drift_slam;
using sds::bench::Report;

sds::loop::LoopConstraint readConstraint(const std::string& summary_path) {
  std::ifstream file(summary_path);
  const nlohmann::json summary = nlohmann::json::parse(file);
  const nlohmann::json& loop = summary.at("loops").at(0);
  const std::vector<double> data = loop.at("S_current_loop").get<std::vector<double>>();
  sds::loop::LoopConstraint constraint;
  constraint.current_id = loop.at("current_keyframe").get<sds::map::KeyframeId>();
  constraint.loop_id = loop.at("loop_keyframe").get<sds::map::KeyframeId>();
  constraint.S_current_loop = sds::geometry::Sim3::fromData(data.data());
  constraint.scale = constraint.S_current_loop.scale();
  return constraint;
}

/// ATE (m, rmse) of the keyframes after Sim(3) alignment to the ground truth, and the path.
std::pair<double, double> keyframeAte(const sds::map::Map& map, const std::string& groundtruth) {
  std::vector<sds::io::StampedPose> estimate;
  for (const auto& [id, keyframe] : map.keyframes())
    estimate.push_back({keyframe.timestamp, keyframe.T_kf_world.inverse()});
  const auto evaluation =
      sds::evaluation::evaluateTrajectory(sds::io::loadTrajectory(groundtruth), estimate);
  return {evaluation.ate.rmse, evaluation.truth_path_length};
}

void replay(Report& report, const std::string& name, const sds::io::MapFile& file,
            const sds::mapping::MapperParams& params, const sds::loop::LoopConstraint& constraint,
            const std::string& groundtruth) {
  const double focal = file.calibration.fx;
  const int kRepetitions = 3;
  std::vector<sds::mapping::LoopCorrectionStatistics> runs;
  sds::map::Map corrected;
  for (int i = 0; i < kRepetitions; ++i) {
    sds::mapping::Mapper mapper(params, focal, file.snapshot.map, file.snapshot.loop_edges);
    sds::mapping::LoopCorrectionStatistics stats;
    mapper.closeLoop(constraint, &stats);
    runs.push_back(stats);
    if (i == 0) corrected = mapper.map();
  }
  std::sort(runs.begin(), runs.end(),
            [](const auto& a, const auto& b) { return a.total_cpu_ms < b.total_cpu_ms; });
  const sds::mapping::LoopCorrectionStatistics& s = runs[runs.size() / 2];
  std::printf("%s: %s\n", name.c_str(), s.describe().c_str());
  report.add(name + ": correction CPU", s.total_cpu_ms, "ms", "median of 3");
  report.add(name + ": graph build", s.build_ms, "ms");
  report.add(name + ": graph solve", s.graph_ms, "ms",
             std::to_string(s.graph_iterations) + " iterations");
  report.add(name + ": map correction", s.correction_ms, "ms");
  report.add(name + ": structure-only BA", s.structure_ms, "ms",
             std::to_string(s.structure_points) + " points refined, chosen in " +
                 std::to_string(s.structure_selection_ms) + " ms");
  const sds::mapping::ReprojectionStats all =
      sds::mapping::reprojectionStats(corrected, {focal, focal});
  report.add(name + ": reprojection median, whole map", all.median, "px");
  report.add(name + ": reprojection p90, whole map", all.p90, "px");
  report.add(name + ": reprojection rms, whole map", all.rms, "px");
  if (!groundtruth.empty()) {
    const auto [ate, path] = keyframeAte(corrected, groundtruth);
    report.add(name + ": keyframe ATE", ate, "m",
               "of a " + std::to_string(path) + " m path, Sim(3)-aligned");
  }
}

/// The pose graph alone, as Mapper::closeLoop builds it, solved with `options`: its time and how
/// far its camera centres lie from those of `reference` (largest, map units and relative to the
/// path length in map units).
sds::loop::PoseGraphResult solveGraph(Report& report, const std::string& name,
                                      const sds::io::MapFile& file,
                                      const sds::loop::LoopConstraint& constraint,
                                      const sds::loop::PoseGraphOptions& options,
                                      const sds::loop::PoseGraphResult* reference) {
  const sds::mapping::LoopCorrectionParams p;
  const sds::map::Map& map = file.snapshot.map;
  std::vector<sds::loop::PoseGraphEdge> loop_edges = file.snapshot.loop_edges;
  sds::loop::PoseGraphEdge edge;
  edge.from = constraint.current_id;
  edge.to = constraint.loop_id;
  edge.S_from_to = constraint.S_current_loop;
  edge.information *= p.loop_edge_weight;
  edge.kind = sds::loop::EdgeKind::kLoop;
  loop_edges.push_back(edge);
  sds::loop::PoseGraphBuilderOptions builder;
  builder.min_shared_points = p.covisibility_min_shared_points;
  builder.max_covisibility_edges_per_keyframe = p.covisibility_max_edges;
  const double cpu_build = sds::common::threadCpuMs();
  const sds::loop::PoseGraph graph =
      sds::loop::buildPoseGraph(map, {}, loop_edges, {map.keyframes().begin()->first}, builder);
  const double cpu_solve = sds::common::threadCpuMs();
  sds::loop::PoseGraphResult result = graph.optimize(options);
  const double cpu_end = sds::common::threadCpuMs();
  report.add("graph " + name + ": build CPU", cpu_solve - cpu_build, "ms");
  report.add(
      "graph " + name + ": solve CPU", cpu_end - cpu_solve, "ms",
      std::to_string(result.iterations) + " iterations, chi2 " + std::to_string(result.final_chi2));
  if (reference) {
    double largest = 0.0, path = 0.0;
    Eigen::Vector3d previous = Eigen::Vector3d::Zero();
    bool first = true;
    for (const auto& [id, S] : reference->S_kf_world) {
      const Eigen::Vector3d c = sds::loop::cameraCentre(S);
      if (!first) path += (c - previous).norm();
      previous = c;
      first = false;
      largest = std::max(largest, (sds::loop::cameraCentre(result.S_kf_world.at(id)) - c).norm());
    }
    report.add("graph " + name + ": largest camera-centre difference to the reference",
               largest / path, "of the path");
  }
  return result;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) {
    std::printf(
        "bench_loop_correction: skipped, needs a map saved before a loop and the run's "
        "summary.json (usage in test/bench/bench_loop_correction.cpp)\n");
    return 0;
  }
  Report report("loop_correction", argc, argv);
  const sds::io::MapFile file = sds::io::loadMapFile(argv[2]);
  const sds::loop::LoopConstraint constraint = readConstraint(argv[3]);
  const std::string groundtruth = argc > 4 ? argv[4] : "";
  std::printf("map: %zu keyframes, %zu points, %zu observations; loop %u -> %u, scale %.4f\n",
              file.snapshot.map.numKeyframes(), file.snapshot.map.numPoints(),
              file.snapshot.map.numObservations(), constraint.current_id, constraint.loop_id,
              constraint.scale);
  {
    sds::map::Map before = file.snapshot.map;
    const sds::mapping::ReprojectionStats all =
        sds::mapping::reprojectionStats(before, {file.calibration.fx, file.calibration.fx});
    report.add("before the correction: reprojection median, whole map", all.median, "px");
    report.add("before the correction: reprojection p90, whole map", all.p90, "px");
    if (!groundtruth.empty())
      report.add("before the correction: keyframe ATE", keyframeAte(before, groundtruth).first,
                 "m");
  }
  {
    sds::loop::PoseGraphOptions tight = sds::mapping::LoopCorrectionParams().graph;
    tight.function_tolerance = 1e-12;
    tight.gradient_tolerance = 1e-16;
    tight.parameter_tolerance = 1e-16;
    const sds::loop::PoseGraphResult reference =
        solveGraph(report, "reference (tolerance 1e-12)", file, constraint, tight, nullptr);
    for (const double tolerance : {1e-6, 1e-5, 1e-4, 1e-3}) {
      sds::loop::PoseGraphOptions options = sds::mapping::LoopCorrectionParams().graph;
      options.function_tolerance = tolerance;
      char name[64];
      std::snprintf(name, sizeof(name), "tolerance %g", tolerance);
      solveGraph(report, name, file, constraint, options, &reference);
    }
    for (const int passes : {0, 1, 3}) {
      sds::loop::PoseGraphOptions options = sds::mapping::LoopCorrectionParams().graph;
      options.loop_error_passes = passes;
      solveGraph(report, "default, " + std::to_string(passes) + " guess passes", file, constraint,
                 options, &reference);
    }
    for (const double damping : {1e-8, 1e-10, 1e-12}) {
      sds::loop::PoseGraphOptions options = sds::mapping::LoopCorrectionParams().graph;
      options.initial_damping = damping;
      char name[64];
      std::snprintf(name, sizeof(name), "initial damping %g", damping);
      solveGraph(report, name, file, constraint, options, &reference);
    }
    {
      sds::loop::PoseGraphOptions options = sds::mapping::LoopCorrectionParams().graph;
      options.linear_solver = sds::loop::PoseGraphLinearSolver::kEigenSparseCholesky;
      solveGraph(report, "Eigen's sparse Cholesky", file, constraint, options, &reference);
    }
    {
      sds::loop::PoseGraphOptions options = sds::mapping::LoopCorrectionParams().graph;
      options.jacobians = sds::loop::PoseGraphJacobians::kAutoDiff;
      solveGraph(report, "automatic derivatives", file, constraint, options, &reference);
      options.loop_error_passes = 0;
      solveGraph(report, "automatic derivatives, no guess", file, constraint, options, &reference);
      options.jacobians = sds::loop::PoseGraphJacobians::kAnalytic;
      solveGraph(report, "no guess", file, constraint, options, &reference);
    }
    if (std::getenv("SDS_BENCH_CERES_REPORT")) {
      sds::loop::PoseGraphOptions options = sds::mapping::LoopCorrectionParams().graph;
      options.log_progress = true;
      solveGraph(report, "with Ceres' report", file, constraint, options, &reference);
    }
  }
  sds::mapping::MapperParams defaults;
  replay(report, "default", file, defaults, constraint, groundtruth);
  sds::mapping::MapperParams everything = defaults;
  everything.loop_correction.structure_min_shift_px = 0.0;
  replay(report, "structure BA over every point", file, everything, constraint, groundtruth);
  sds::mapping::MapperParams earlier = everything;
  earlier.loop_correction.graph.initial_damping = sds::loop::PoseGraphOptions().initial_damping;
  replay(report, "earlier parameters (every point, damping 1e-6)", file, earlier, constraint,
         groundtruth);
  if (std::getenv("SDS_BENCH_GRAPH_VARIANTS")) {
    sds::mapping::MapperParams variant = defaults;
    variant.loop_correction.graph.function_tolerance = 1e-4;
    replay(report, "graph tolerance 1e-4", file, variant, constraint, groundtruth);
    variant = defaults;
    variant.loop_correction.covisibility_max_edges = 2;
    replay(report, "2 co-visibility edges per keyframe", file, variant, constraint, groundtruth);
    variant = defaults;
    variant.loop_correction.covisibility_max_edges = 1;
    replay(report, "1 co-visibility edge per keyframe", file, variant, constraint, groundtruth);
    variant = defaults;
    variant.loop_correction.covisibility_min_shared_points = 0;
    replay(report, "no co-visibility edges", file, variant, constraint, groundtruth);
  }
  for (const double shift : {0.1, 0.5}) {
    sds::mapping::MapperParams bounded = defaults;
    bounded.loop_correction.structure_min_shift_px = shift;
    char name[64];
    std::snprintf(name, sizeof(name), "structure BA over points moved > %g px", shift);
    replay(report, name, file, bounded, constraint, groundtruth);
  }
  return 0;
}
