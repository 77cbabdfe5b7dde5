#include "scale_drift_slam/sim/sphere_experiment.h"

#include <algorithm>
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
  std::mt19937 rng(seed);
  const SimulatedWorld world = makeSphereWorld(params.world, rng);
  // Every loop the simulated data association reveals, all corrected at once.
  const LoopMeasurer detect_loops = [&](const SimulatedVisualOdometry& vo) {
    std::vector<loop::LoopConstraint> loops =
        detectLoops(vo, world.camera.focal_length, params.detection);
    if (loops.empty()) throw std::runtime_error("sphere experiment: no loop was detected");
    return loops;
  };
  return runExperiment("sphere", world, voParamsForNoise(params.vo, params.noise_px),
                       params.noise_px, seed, rng, detect_loops, params.correction);
}

}  // namespace scale_drift_slam::sim
