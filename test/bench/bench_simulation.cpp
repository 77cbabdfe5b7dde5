// The paper's simulations as benchmarks (doc/benchmarks.md, "Back-end"): a full circle run (720
// poses, 1 px noise: visual odometry with filters and window BA, the loop, both corrections) and
// a full sphere run (3000 poses, 0.75 px, 10 loops), in process CPU time, and the per-call cost
// of the window BA and motion-only BA inside those runs. Measures; asserts nothing about time.

#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "bench_report.h"
#include "scale_drift_slam/sim/circle_experiment.h"
#include "scale_drift_slam/sim/sphere_experiment.h"

namespace sds = scale_drift_slam;

namespace {

double median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  return values[values.size() / 2];
}

void reportRuns(sds::bench::Report& report, const std::string& name,
                const std::vector<sds::sim::SimulationRun>& runs) {
  std::vector<double> cpu, vo, window_ms, motion_ms, window_obs;
  for (const sds::sim::SimulationRun& run : runs) {
    cpu.push_back(run.total_cpu_time_s);
    vo.push_back(run.vo_time_s);
    window_ms.push_back(run.vo.window_ba_ms / std::max<std::size_t>(1, run.vo.window_ba_runs));
    motion_ms.push_back(run.vo.motion_ba_ms / std::max<std::size_t>(1, run.vo.frames));
  }
  const std::string note = "median of " + std::to_string(runs.size()) + " seeds, max " +
                           std::to_string(*std::max_element(cpu.begin(), cpu.end())) + " s";
  report.add(name + ": whole run, process CPU", median(cpu), "s", note);
  report.add(name + ": visual odometry, wall", median(vo), "s");
  report.add(name + ": window BA per keyframe (in the run)", median(window_ms), "ms");
  report.add(name + ": motion-only BA per frame (in the run)", median(motion_ms), "ms");
  report.add(name + ": keyframes", static_cast<double>(runs.front().keyframes), "");
  report.add(name + ": loops", static_cast<double>(runs.front().loops.size()), "");
}

}  // namespace

int main(int argc, char** argv) {
  try {
    sds::bench::Report report("simulation", argc, argv);
    std::vector<sds::sim::SimulationRun> circles;
    for (std::uint32_t seed = 1; seed <= 5; ++seed)
      circles.push_back(sds::sim::runCircleExperiment(sds::sim::CircleExperimentParams(), seed));
    reportRuns(report, "circle, 720 poses, 1 px", circles);
    std::vector<sds::sim::SimulationRun> spheres;
    for (std::uint32_t seed = 1; seed <= 3; ++seed)
      spheres.push_back(sds::sim::runSphereExperiment(sds::sim::SphereExperimentParams(), seed));
    reportRuns(report, "sphere, 3000 poses, 0.75 px", spheres);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "bench_simulation: %s\n", error.what());
    return 1;
  }
  return 0;
}
