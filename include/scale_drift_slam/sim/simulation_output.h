#pragma once
// Output of the paper's simulations (sim/circle_experiment.h, sim/sphere_experiment.h): the
// summary JSON, TUM trajectories and PNG plots written by `scale_drift_experiment circle|sphere`.
//   one run:     DIR/summary.json, DIR/{truth,before,se3,sim3}.tum (every frame, T_world_cam,
//                timestamp = frame index), DIR/<experiment>_top_view.png;
//   N runs:      the same per run in DIR/run_<k>/, DIR/summary.json with every run's figures and
//                their mean and median, and run 0's trajectories and plot in DIR as well;
//   noise sweep: DIR/summary.json (per level: runs, mean, median) and DIR/noise_sweep.png
//                (position RMSE of SE(3) and Sim(3) against the noise, and the scale drift).
// Throws std::runtime_error when a file cannot be written.

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "scale_drift_slam/sim/simulation_run.h"

namespace scale_drift_slam::sim {

/// The figures of one run.
nlohmann::json runJson(const SimulationRun& run);

/// Mean and median over runs of the errors, the Sim(3)/SE(3) ratio, the loop scale and the times.
nlohmann::json aggregateJson(const std::vector<SimulationRun>& runs);

/// Writes one run into `dir` (created when missing); `params` is copied into the summary.
void writeRun(const SimulationRun& run, const nlohmann::json& params, const std::string& dir);

/// Writes a set of runs with the same parameters (one run: as writeRun).
void writeRuns(const std::vector<SimulationRun>& runs, const nlohmann::json& params,
               const std::string& dir);

/// The runs at one noise level of a sweep.
struct NoiseLevelRuns {
  double noise_px = 0.0;
  std::vector<SimulationRun> runs;
};

/// Writes a noise sweep (summary.json and noise_sweep.png).
void writeNoiseSweep(const std::vector<NoiseLevelRuns>& levels, const nlohmann::json& params,
                     const std::string& dir);

}  // namespace scale_drift_slam::sim
