#pragma once
// Loop-closure correction of a finished simulated visual-odometry run, Sim(3) against SE(3)
// (doc/algorithm.md, "Loop closure correction" and "The paper's evidence"). The pose graph is
// built from the VO's keyframe map: every keyframe a vertex (scale 1), consecutive edges
// S_ij = T_i T_j^-1, optionally co-visibility edges, and the loop edges measured from the
// observations (sim/loop_measurement.h); the first keyframe is fixed. The same graph is solved
// once as Sim(3) and once as SE(3). Every frame then follows the correction of its reference
// keyframe (sim/simulated_visual_odometry.h, FrameRecord), and the paper's error measure
// (evaluation::firstPoseAlignedError) compares the drifted, the SE(3) and the Sim(3) trajectory
// with the truth. Pure functions of a finished run; any thread.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "scale_drift_slam/evaluation/alignment.h"
#include "scale_drift_slam/loop/loop_constraint.h"
#include "scale_drift_slam/loop/pose_graph.h"
#include "scale_drift_slam/sim/simulated_visual_odometry.h"
#include "scale_drift_slam/sim/simulated_world.h"

namespace scale_drift_slam::sim {

/// How the pose graph of a run is built and solved.
struct CorrectionOptions {
  /// Solver settings shared by both variants (the mode is set per variant).
  loop::PoseGraphOptions graph;
  /// Also join keyframes sharing at least this many map points (0: consecutive edges only).
  int covisibility_min_shared_points = 0;
  /// Information of the consecutive and co-visibility edges, identity times this (the authors'
  /// code uses identity for every edge).
  double odometry_information = 1.0;
  /// Information of the loop edges, identity times this.
  double loop_information = 1.0;
  /// Throws std::invalid_argument naming the first bad value.
  void validate() const;
};

/// One loop of a run: where it joins, what it measured and what the truth says.
struct LoopRecord {
  std::size_t current_keyframe = 0;  ///< Indices into SimulatedVisualOdometry::keyframes().
  std::size_t loop_keyframe = 0;
  std::size_t current_frame = 0;
  std::size_t loop_frame = 0;
  double measured_scale = 1.0;  ///< s of the constraint: current map units per loop map unit.
  double true_scale = 1.0;      ///< The same ratio from the map against the truth (localMapScale).
  int inliers = 0;
  int scale_pairs = 0;
  double rmse_px = 0.0;
};

/// One corrected trajectory.
struct CorrectedTrajectory {
  std::string name;  ///< "se3" or "sim3".
  loop::PoseGraphResult graph;
  std::vector<geometry::SE3> T_world_cam;  ///< Every frame.
  evaluation::FirstPoseAlignedError error;
};

struct GraphSummary {
  std::size_t vertices = 0;
  std::size_t consecutive_edges = 0;
  std::size_t covisibility_edges = 0;
  std::size_t loop_edges = 0;
};

/// Everything a run produced, for the JSON and the plots (sim/simulation_output.h).
struct SimulationRun {
  std::string experiment;  ///< "circle" or "sphere".
  std::uint32_t seed = 0;
  double noise_px = 0.0;
  std::size_t frames = 0;
  std::size_t keyframes = 0;
  std::size_t points = 0;
  std::size_t observations = 0;
  SimulatedVoStatistics vo;
  std::vector<LoopRecord> loops;
  GraphSummary graph;
  std::vector<geometry::SE3> T_world_cam_truth;   ///< Every frame.
  std::vector<geometry::SE3> T_world_cam_before;  ///< The VO's, through its keyframes.
  evaluation::FirstPoseAlignedError error_before;
  CorrectedTrajectory se3;
  CorrectedTrajectory sim3;
  /// Wall and process CPU time of the stages (seconds).
  double vo_time_s = 0.0;
  double loop_time_s = 0.0;
  double correction_time_s = 0.0;
  double total_time_s = 0.0;
  double total_cpu_time_s = 0.0;
};

/// The map's local scale at keyframe `k` (index into vo.keyframes()): the median over its points
/// of (estimated distance from the camera) / (true distance). 1 means metric; a loop's true scale
/// change is localMapScale(current) / localMapScale(loop). NaN when the keyframe sees no point.
double localMapScale(const SimulatedVisualOdometry& vo, const SimulatedWorld& world, std::size_t k);

/// The loop record of a measured constraint (true scale from localMapScale).
LoopRecord makeLoopRecord(const SimulatedVisualOdometry& vo, const SimulatedWorld& world,
                          const loop::LoopConstraint& constraint);

/// The pose graph of a run (see the file comment). Loop edges go from the current keyframe to
/// the loop keyframe with S_current_loop. Throws std::invalid_argument for invalid options.
loop::PoseGraph makeRunPoseGraph(const SimulatedVisualOdometry& vo,
                                 const std::vector<loop::LoopConstraint>& loops,
                                 const CorrectionOptions& options);

/// Every frame's pose after a correction of the keyframes (S_kf_world by keyframe id): the
/// frame's similarity Sim3(T_frame_kf) S_kf_world as a rigid pose (rotation kept, same camera
/// centre), returned as T_world_cam.
std::vector<geometry::SE3> correctedFramePoses(
    const SimulatedVisualOdometry& vo, const std::map<map::KeyframeId, geometry::Sim3>& S_kf_world);

/// Builds the graph, solves it in both modes and measures the errors. Fills every field of the
/// result except experiment, seed, noise_px and the times of the VO and loop stages.
SimulationRun correctRun(const SimulatedVisualOdometry& vo, const SimulatedWorld& world,
                         const std::vector<loop::LoopConstraint>& loops,
                         const CorrectionOptions& options);

/// What an experiment measures on the VO's keyframes: its loop constraints (throws when none).
using LoopMeasurer =
    std::function<std::vector<loop::LoopConstraint>(const SimulatedVisualOdometry& vo)>;

/// An experiment from its world on: the VO over every frame (measurements with `noise_px` of
/// Gaussian noise from `rng`), the loops, both corrections, and the times of each stage.
SimulationRun runExperiment(const std::string& name, const SimulatedWorld& world,
                            const SimulatedVoParams& vo_params, double noise_px, std::uint32_t seed,
                            std::mt19937& rng, const LoopMeasurer& measure_loops,
                            const CorrectionOptions& correction);

/// Process CPU time in seconds (for the run-time figures).
double processCpuSeconds();

}  // namespace scale_drift_slam::sim
