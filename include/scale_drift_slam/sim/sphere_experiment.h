#pragma once
// The paper's multi-loop simulation (doc/algorithm.md, "The paper's evidence"): an aircraft
// flies great circles over a sphere of points with a downward camera (sim/simulated_world.h), the
// back-end runs as visual odometry, the loops are detected from the simulated data association
// and measured from the observations (sim/loop_measurement.h), and all of them are corrected at
// once with Sim(3) and with SE(3) (sim/simulation_run.h). Pure function; any thread.

#include <cstdint>

#include "scale_drift_slam/sim/loop_measurement.h"
#include "scale_drift_slam/sim/simulated_visual_odometry.h"
#include "scale_drift_slam/sim/simulated_world.h"
#include "scale_drift_slam/sim/simulation_run.h"

namespace scale_drift_slam::sim {

struct SphereExperimentParams {
  SphereWorldParams world;
  double noise_px = 0.75;  ///< Gaussian pixel noise (standard deviation per coordinate).
  SimulatedVoParams vo;
  LoopDetectionParams detection;
  CorrectionOptions correction;
  SphereExperimentParams();
  /// Throws std::invalid_argument naming the first bad value.
  void validate() const;
};

/// One run with the given seed. Throws std::runtime_error when no loop is detected.
SimulationRun runSphereExperiment(const SphereExperimentParams& params, std::uint32_t seed);

}  // namespace scale_drift_slam::sim
