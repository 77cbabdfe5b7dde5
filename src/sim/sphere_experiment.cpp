#include "scale_drift_slam/sim/sphere_experiment.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>
#include <stdexcept>

namespace scale_drift_slam::sim {

SphereExperimentParams::SphereExperimentParams() {
  // As for the circle (sim/circle_experiment.cpp): the old map points carry the drift.
  detection.measurement.constraint.ransac_threshold_px = 6.0;
}

void SphereExperimentParams::validate() const {
  world.validate();
  vo.validate();
  detection.validate();
  correction.validate();
  if (!(noise_px >= 0.0) || !std::isfinite(noise_px)) {
    throw std::invalid_argument("sphere experiment: the noise must be >= 0 pixels");
  }
}

SimulationRun runSphereExperiment(const SphereExperimentParams& params, std::uint32_t seed) {
  params.validate();
  const auto start = std::chrono::steady_clock::now();
  const double cpu_start = processCpuSeconds();
  std::mt19937 rng(seed);
  const SimulatedWorld world = makeSphereWorld(params.world, rng);
  const SimulatedVoParams vo_params = voParamsForNoise(params.vo, params.noise_px);
  SimulatedVisualOdometry vo(world.camera, vo_params);
  for (std::size_t i = 0; i < world.T_cam_world.size(); ++i)
    vo.processFrame(i, measureFrame(world, i, params.noise_px, rng), world.T_cam_world[i]);
  const auto vo_end = std::chrono::steady_clock::now();

  const std::vector<loop::LoopConstraint> loops =
      detectLoops(vo, world.camera.focal_length, params.detection);
  if (loops.empty()) throw std::runtime_error("sphere experiment: no loop was detected");
  const auto loop_end = std::chrono::steady_clock::now();
  SimulationRun run = correctRun(vo, world, loops, params.correction);
  run.experiment = "sphere";
  run.seed = seed;
  run.noise_px = params.noise_px;
  run.vo_time_s = std::chrono::duration<double>(vo_end - start).count();
  run.loop_time_s = std::chrono::duration<double>(loop_end - vo_end).count();
  run.total_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  run.total_cpu_time_s = processCpuSeconds() - cpu_start;
  return run;
}

}  // namespace scale_drift_slam::sim
