// scale_drift_experiment: the paper's experiments, Sim(3) versus SE(3) loop-closure correction.
// A thin dispatcher: each subcommand parses its flags and calls the experiment in the core
// (sim/). Add an experiment by adding an entry to experiments().

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "scale_drift_slam/io/command_line.h"
#include "scale_drift_slam/io/keble_map.h"
#include "scale_drift_slam/sim/circle_experiment.h"
#include "scale_drift_slam/sim/keble_experiment.h"
#include "scale_drift_slam/sim/simulation_output.h"
#include "scale_drift_slam/sim/sphere_experiment.h"

namespace {

namespace sds = scale_drift_slam;
using scale_drift_slam::io::CommandLine;

const char* const kUsage =
    "Usage: scale_drift_experiment EXPERIMENT --out DIR [flags]\n"
    "The paper's experiments: loop-closure correction with a Sim(3) versus an SE(3) pose graph.\n"
    "Writes DIR/summary.json, DIR/before.tum, DIR/se3.tum, DIR/sim3.tum and a PNG plot.\n"
    "\n"
    "Experiments:\n"
    "  keble --map FILE --out DIR   the Keble College map (paper Figure 2), e.g.\n"
    "        test/data/keble_college/keble_college.txt. Also writes se3_points.txt,\n"
    "        sim3_points.txt (corrected points) and keble_top_view.png (x-z top view).\n"
    "        --max-iterations N     LM iterations of each pose graph (default 100: converged;\n"
    "                               the authors capped theirs at 2)\n"
    "        --jacobians analytic|autodiff   pose-graph derivatives (default analytic)\n"
    "        --structure-iterations N        structure-only BA iterations (default 10)\n"
    "        --covisibility N       add edges between keyframes sharing >= N points (default 0)\n"
    "        --loop-error-passes N  passes of the initial guess that spreads the loop's error\n"
    "                               along the odometry before LM (default 3; 0: LM starts from\n"
    "                               the map's poses)\n"
    "  circle --out DIR        the paper's circle (Figure 3): 720 poses on a circle of radius\n"
    "        10 m looking outwards at 5000 points on a ring of radius 11 m; visual odometry with\n"
    "        feature filters and a window BA of 10, the loop last -> first keyframe measured from\n"
    "        the observations, corrected with SE(3) and Sim(3). Writes truth.tum too and\n"
    "        circle_top_view.png.\n"
    "        --noise PX             Gaussian pixel noise (default 1.0)\n"
    "        --poses N              poses on the circle (default 720); --points N (default 5000)\n"
    "        --noise-sweep          every noise level of Figure 3 (0, 0.2, ..., 1.2 px) instead:\n"
    "                               summary.json and noise_sweep.png\n"
    "  sphere --out DIR        the paper's multi-loop run: 15000 points on a sphere of radius\n"
    "        10 m, a downward camera on great circles at 12 m, loops detected from the simulated\n"
    "        data association, all corrected at once. Writes sphere_top_view.png.\n"
    "        --noise PX             Gaussian pixel noise (default 0.75)\n"
    "        --revolutions N        great circles flown (default 6: 10 loops)\n"
    "  circle and sphere also take:\n"
    "        --runs N --seed S      N runs with the seeds S, S+1, ... (default 1 run, seed 1);\n"
    "                               runs > 1 write DIR/run_NN/ and mean/median in summary.json\n"
    "        --covisibility N       also join keyframes sharing >= N points (default 0)\n"
    "        --loop-information W   information of the loop edges, identity times W (default 1)\n"
    "        --max-iterations N     LM iterations of each pose graph (default 100)\n";

int runKeble(const CommandLine& args) {
  args.rejectUnknownFlags({"map", "out", "max-iterations", "jacobians", "structure-iterations",
                           "covisibility", "loop-error-passes"});
  sds::sim::KebleExperimentOptions options;
  options.graph.max_iterations = static_cast<int>(args.integer("max-iterations", 100));
  options.graph.loop_error_passes = static_cast<int>(
      args.integer("loop-error-passes", sds::loop::PoseGraphOptions().loop_error_passes));
  options.graph.jacobians = sds::loop::parsePoseGraphJacobians(args.text("jacobians", "analytic"));
  options.structure.max_iterations = static_cast<int>(args.integer("structure-iterations", 10));
  options.min_shared_points = static_cast<int>(args.integer("covisibility", 0));
  options.validate();
  const std::string out = args.required("out");
  const sds::io::KebleMap keble = sds::io::loadKebleMap(args.required("map"));
  const sds::sim::KebleExperimentResult result = sds::sim::runKebleExperiment(keble, options);
  sds::sim::writeKebleExperiment(result, keble, out);
  std::printf("Keble College: %zu keyframes, %zu points, %zu observations; loop %u -> %u\n",
              keble.map.numKeyframes(), keble.map.numPoints(), keble.map.numObservations(),
              result.last_keyframe, result.loop_keyframe);
  std::printf("  %-7s path %6.2f  loop gap %.3f  median reprojection %.2f px\n", "before",
              result.path_length_before, result.loop_gap_before, result.reprojection_before.median);
  for (const auto* variant : {&result.se3, &result.sim3}) {
    std::printf(
        "  %-7s path %6.2f  loop gap %.3f  median reprojection %.2f px  (graph %d it, %.1f ms; "
        "structure-only BA %.1f ms)\n",
        variant->name.c_str(), variant->path_length, variant->loop_gap,
        variant->structure.after.median, variant->graph.iterations, 1e3 * variant->graph.time_s,
        1e3 * variant->structure.time_s);
  }
  std::printf("outputs in %s\n", out.c_str());
  return 0;
}

/// The flags circle and sphere share.
const std::set<std::string> kSimulationFlags = {
    "out", "noise", "runs", "seed", "covisibility", "loop-information", "max-iterations"};

sds::sim::CorrectionOptions correctionOptions(const CommandLine& args) {
  sds::sim::CorrectionOptions options;
  options.covisibility_min_shared_points = static_cast<int>(args.integer("covisibility", 0));
  options.loop_information = args.number("loop-information", 1.0);
  options.graph.max_iterations = static_cast<int>(args.integer("max-iterations", 100));
  options.validate();
  return options;
}

/// --runs and --seed: the seeds of the runs.
std::vector<std::uint32_t> seeds(const CommandLine& args) {
  const long runs = args.integer("runs", 1), seed = args.integer("seed", 1);
  if (runs < 1 || runs > 1000) throw std::invalid_argument("--runs must be in 1..1000");
  if (seed < 0 || seed > 0xFFFFFFFFL - runs) throw std::invalid_argument("--seed out of range");
  std::vector<std::uint32_t> list;
  for (long k = 0; k < runs; ++k)
    list.push_back(static_cast<std::uint32_t>(seed + k));
  return list;
}

void printRun(const sds::sim::SimulationRun& run) {
  double scale = 1.0;
  for (const auto& loop : run.loops) {
    if (std::abs(std::log(loop.measured_scale)) > std::abs(std::log(scale)))
      scale = loop.measured_scale;
  }
  std::printf(
      "  %s seed %u noise %.2f px: %zu keyframes, %zu loops (largest scale change %+.1f%%); "
      "RMSE before %.3f, SE(3) %.3f, Sim(3) %.3f; %.1f s CPU\n",
      run.experiment.c_str(), run.seed, run.noise_px, run.keyframes, run.loops.size(),
      100.0 * (scale - 1.0), run.error_before.rmse, run.se3.error.rmse, run.sim3.error.rmse,
      run.total_cpu_time_s);
}

nlohmann::json commonJson(const CommandLine& args, const sds::sim::CorrectionOptions& correction,
                          double noise) {
  return {{"noise_px", noise},
          {"runs", args.integer("runs", 1)},
          {"seed", args.integer("seed", 1)},
          {"covisibility_min_shared_points", correction.covisibility_min_shared_points},
          {"odometry_information", correction.odometry_information},
          {"loop_information", correction.loop_information},
          {"pose_graph_max_iterations", correction.graph.max_iterations}};
}

int runCircle(const CommandLine& args) {
  std::set<std::string> known = kSimulationFlags;
  known.insert({"poses", "points", "noise-sweep"});
  args.rejectUnknownFlags(known);
  sds::sim::CircleExperimentParams params;
  params.noise_px = args.number("noise", 1.0);
  params.world.num_poses = static_cast<int>(args.integer("poses", 720));
  params.world.num_points = static_cast<int>(args.integer("points", 5000));
  params.correction = correctionOptions(args);
  params.validate();
  const std::string out = args.required("out");
  const std::vector<std::uint32_t> run_seeds = seeds(args);
  nlohmann::json json = commonJson(args, params.correction, params.noise_px);
  json["poses"] = params.world.num_poses;
  json["points"] = params.world.num_points;
  json["window_size"] = params.vo.window.window_size;
  if (!args.has("noise-sweep")) {
    std::vector<sds::sim::SimulationRun> runs;
    for (std::uint32_t seed : run_seeds) {
      runs.push_back(sds::sim::runCircleExperiment(params, seed));
      printRun(runs.back());
    }
    sds::sim::writeRuns(runs, json, out);
    std::printf("outputs in %s\n", out.c_str());
    return 0;
  }
  if (args.has("noise"))
    throw std::invalid_argument("--noise and --noise-sweep exclude each other");
  json.erase("noise_px");
  std::vector<sds::sim::NoiseLevelRuns> levels;
  for (double noise : sds::sim::paperNoiseLevels()) {
    params.noise_px = noise;
    levels.push_back({noise, {}});
    for (std::uint32_t seed : run_seeds) {
      levels.back().runs.push_back(sds::sim::runCircleExperiment(params, seed));
      printRun(levels.back().runs.back());
    }
  }
  sds::sim::writeNoiseSweep(levels, json, out);
  std::printf("outputs in %s\n", out.c_str());
  return 0;
}

int runSphere(const CommandLine& args) {
  std::set<std::string> known = kSimulationFlags;
  known.insert("revolutions");
  args.rejectUnknownFlags(known);
  sds::sim::SphereExperimentParams params;
  params.noise_px = args.number("noise", 0.75);
  params.world.revolutions = static_cast<int>(args.integer("revolutions", 6));
  params.correction = correctionOptions(args);
  params.validate();
  const std::string out = args.required("out");
  nlohmann::json json = commonJson(args, params.correction, params.noise_px);
  json["revolutions"] = params.world.revolutions;
  json["poses_per_revolution"] = params.world.poses_per_revolution;
  json["points"] = params.world.num_points;
  json["window_size"] = params.vo.window.window_size;
  std::vector<sds::sim::SimulationRun> runs;
  for (std::uint32_t seed : seeds(args)) {
    runs.push_back(sds::sim::runSphereExperiment(params, seed));
    printRun(runs.back());
  }
  sds::sim::writeRuns(runs, json, out);
  std::printf("outputs in %s\n", out.c_str());
  return 0;
}

/// The experiments by name.
const std::map<std::string, std::function<int(const CommandLine&)>>& experiments() {
  static const std::map<std::string, std::function<int(const CommandLine&)>> table = {
      {"keble", runKeble}, {"circle", runCircle}, {"sphere", runSphere}};
  return table;
}

}  // namespace

int main(int argc, char** argv) {
  return sds::io::runTool(argc, argv, kUsage, {"noise-sweep"}, [](const CommandLine& args) {
    const std::string& name = args.positional(0, "EXPERIMENT (keble, circle, sphere)");
    const auto it = experiments().find(name);
    if (it == experiments().end()) {
      std::string known;
      for (const auto& entry : experiments()) {
        known += (known.empty() ? "" : ", ") + entry.first;
      }
      throw std::invalid_argument("unknown experiment '" + name + "' (known: " + known + ")");
    }
    if (args.positional().size() > 1) {
      throw std::invalid_argument("unexpected argument '" + args.positional()[1] + "'");
    }
    return it->second(args);
  });
}
