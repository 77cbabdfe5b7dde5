#pragma once
// The paper's circle simulation (doc/algorithm.md, "The paper's evidence", Figure 3): a camera
// on a circle of radius 10 m looking outwards at a ring of points, the whole back-end run as
// visual odometry (sim/simulated_visual_odometry.h: feature filters, keyframe rule, window BA of
// 10, data association from the simulation), then the loop between the last keyframe and the
// first is measured from the observations (sim/loop_measurement.h) and corrected with Sim(3)
// and with SE(3) (sim/simulation_run.h). Also the noise sweep of Figure 3. Pure functions of
// their parameters and seeds; any thread.

#include <cstdint>
#include <vector>

#include "scale_drift_slam/sim/loop_measurement.h"
#include "scale_drift_slam/sim/simulated_visual_odometry.h"
#include "scale_drift_slam/sim/simulated_world.h"
#include "scale_drift_slam/sim/simulation_run.h"

namespace scale_drift_slam::sim {

struct CircleExperimentParams {
  CircleWorldParams world;
  double noise_px = 1.0;  ///< Gaussian pixel noise (standard deviation per coordinate).
  SimulatedVoParams vo;
  /// The loop measurement (P3P RANSAC + refinement + median scale); its threshold is in pixels.
  LoopMeasurementParams loop;
  CorrectionOptions correction;
  CircleExperimentParams();
  /// Throws std::invalid_argument naming the first bad value.
  void validate() const;
};

/// One run with the given seed (world and noise both drawn from it). Throws std::runtime_error
/// when the loop cannot be measured (with the reason).
SimulationRun runCircleExperiment(const CircleExperimentParams& params, std::uint32_t seed);

/// The noise levels of the paper's Figure 3: 0, 0.2, ..., 1.2 px.
std::vector<double> paperNoiseLevels();

}  // namespace scale_drift_slam::sim
