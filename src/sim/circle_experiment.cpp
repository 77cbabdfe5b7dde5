#include "scale_drift_slam/sim/circle_experiment.h"

#include <algorithm>
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
  std::mt19937 rng(seed);
  const SimulatedWorld world = makeCircleWorld(params.world, rng);
  // The loop between the last keyframe and the first, measured from the observations.
  const LoopMeasurer measure_loop = [&](const SimulatedVisualOdometry& vo) {
    const loop::LoopConstraintResult loop =
        measureLoop(vo, vo.keyframes().size() - 1, 0, world.camera.focal_length, params.loop);
    if (!loop.success) {
      throw std::runtime_error("circle experiment: the loop could not be measured: " + loop.reason);
    }
    return std::vector<loop::LoopConstraint>{loop.constraint};
  };
  return runExperiment("circle", world, voParamsForNoise(params.vo, params.noise_px),
                       params.noise_px, seed, rng, measure_loop, params.correction);
}

std::vector<double> paperNoiseLevels() {
  return {0.0, 0.2, 0.4, 0.6, 0.8, 1.0, 1.2};
}

}  // namespace scale_drift_slam::sim
