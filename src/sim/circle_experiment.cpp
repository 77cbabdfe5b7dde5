#include "scale_drift_slam/sim/circle_experiment.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>
#include <stdexcept>

#include "scale_drift_slam/sim/loop_measurement.h"

namespace scale_drift_slam::sim {

CircleExperimentParams::CircleExperimentParams() {
  // The map points at the loop keyframe carry the whole drift of the early map plus 1 px of
  // noise per observation: 6 px keeps every true match of a 1.2 px run an inlier, and no false
  // match exists (data association is given).
  loop.constraint.ransac_threshold_px = 6.0;
}

void CircleExperimentParams::validate() const {
  world.validate();
  vo.validate();
  loop.validate();
  correction.validate();
  if (!(noise_px >= 0.0) || !std::isfinite(noise_px)) {
    throw std::invalid_argument("circle experiment: the noise must be >= 0 pixels");
  }
}

SimulationRun runCircleExperiment(const CircleExperimentParams& params, std::uint32_t seed) {
  params.validate();
  const auto start = std::chrono::steady_clock::now();
  const double cpu_start = processCpuSeconds();
  std::mt19937 rng(seed);
  const SimulatedWorld world = makeCircleWorld(params.world, rng);
  const SimulatedVoParams vo_params = voParamsForNoise(params.vo, params.noise_px);
  SimulatedVisualOdometry vo(world.camera, vo_params);
  for (std::size_t i = 0; i < world.T_cam_world.size(); ++i)
    vo.processFrame(i, measureFrame(world, i, params.noise_px, rng), world.T_cam_world[i]);
  const auto vo_end = std::chrono::steady_clock::now();

  const std::size_t last = vo.keyframes().size() - 1;
  const loop::LoopConstraintResult loop =
      measureLoop(vo, last, 0, world.camera.focal_length, params.loop);
  if (!loop.success) {
    throw std::runtime_error("circle experiment: the loop could not be measured: " + loop.reason);
  }
  const auto loop_end = std::chrono::steady_clock::now();
  SimulationRun run = correctRun(vo, world, {loop.constraint}, params.correction);
  run.experiment = "circle";
  run.seed = seed;
  run.noise_px = params.noise_px;
  run.vo_time_s = std::chrono::duration<double>(vo_end - start).count();
  run.loop_time_s = std::chrono::duration<double>(loop_end - vo_end).count();
  run.total_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  run.total_cpu_time_s = processCpuSeconds() - cpu_start;
  return run;
}

std::vector<double> paperNoiseLevels() {
  return {0.0, 0.2, 0.4, 0.6, 0.8, 1.0, 1.2};
}

}  // namespace scale_drift_slam::sim
