// scale_drift_experiment: the paper's experiments, Sim(3) versus SE(3) loop-closure correction.
// A thin dispatcher: each subcommand parses its flags and calls the experiment in the core
// (sim/). Add an experiment by adding an entry to experiments().

#include <cstdio>
#include <functional>
#include <map>
#include <stdexcept>
#include <string>

#include "scale_drift_slam/io/command_line.h"
#include "scale_drift_slam/io/keble_map.h"
#include "scale_drift_slam/sim/keble_experiment.h"

namespace {

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
    "        --covisibility N       add edges between keyframes sharing >= N points (default 0)\n";

int runKeble(const CommandLine& args) {
  namespace sds = scale_drift_slam;
  args.rejectUnknownFlags(
      {"map", "out", "max-iterations", "jacobians", "structure-iterations", "covisibility"});
  sds::sim::KebleExperimentOptions options;
  options.graph.max_iterations = static_cast<int>(args.integer("max-iterations", 100));
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

/// The experiments by name; "circle" and "sphere" join here.
const std::map<std::string, std::function<int(const CommandLine&)>>& experiments() {
  static const std::map<std::string, std::function<int(const CommandLine&)>> table = {
      {"keble", runKeble}};
  return table;
}

}  // namespace

int main(int argc, char** argv) {
  return scale_drift_slam::io::runTool(argc, argv, kUsage, {}, [](const CommandLine& args) {
    const std::string& name = args.positional(0, "EXPERIMENT (keble)");
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
