#pragma once
// Synthetic pose graphs with known truth for testing and benchmarking loop-closure correction.
// A camera circles (one or more laps, looking outwards, as in the paper's simulation) and a
// monocular odometry drifts in rotation, translation and SCALE:
//   V_i = [s_i R_i, s_i t_i]: the true pose T_i in keyframe i's local map units (the "true
//         similarity": its camera centre is the true one), log s_i a random walk with a mean
//         step (the scale drift), s_0 = 1;
//   M_i = exp(n_i) [R, t] of V_i V_{i-1}^-1 = [(s_i / s_{i-1}) R, t]: the odometry measures
//         the relative motion in its current units, scale ratio dropped, with noise n_i;
//   E_i = M_i E_{i-1}, E_0 = T_0: the drifting rigid estimate.
// Consecutive edges are measured from the estimate with scale 1 (E_i E_{i-1}^-1 = M_i, as the
// paper builds them); loop edges measure the truth in local units, V_i V_j^-1, so they carry the
// true relative scale s_i / s_j. The truth V violates the consecutive edges only by the small
// scale steps and the noise, so a Sim(3) graph returns close to it; an SE(3) graph cannot undo
// the scale drift.

#include <cstdint>
#include <map>
#include <vector>

#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/geometry/sim3.h"
#include "scale_drift_slam/loop/pose_graph.h"

namespace scale_drift_slam::sim {

struct DriftingPoseGraphOptions {
  int keyframes_per_lap = 200;
  int laps = 1;
  double radius = 10.0;  ///< Of the circle in the world x-z plane (y points down).
  /// Loop edges: from evenly spaced keyframes of laps 2.. (or, with one lap, the last keyframe)
  /// back to the keyframe at the same place in the first lap.
  int loops = 1;
  /// Extra edges from each keyframe to its k previous ones besides the consecutive one
  /// (co-visibility), measured like the consecutive edges.
  int covisibility_neighbours = 0;
  double log_scale_drift_per_keyframe = 0.0;  ///< Mean step of log s_i.
  double log_scale_noise = 0.0;               ///< Std dev of the step of log s_i.
  double rotation_noise = 0.0;                ///< Std dev (rad) of the odometry's rotation noise.
  double translation_noise = 0.0;             ///< Std dev of its translation noise (local units).
  std::uint32_t seed = 1;

  /// Throws std::invalid_argument naming the offending field.
  void validate() const;
};

/// Ground truth and the graph built from the drifting estimate. Keyframe ids are 0..n-1;
/// vertex 0 is fixed (E_0 = V_0 = T_0).
struct DriftingPoseGraph {
  loop::PoseGraph graph;
  std::vector<geometry::SE3> T_kf_world_true;
  std::vector<geometry::Sim3> S_kf_world_true;  ///< V_i: the truth in the local map units.
  std::vector<geometry::SE3> T_kf_world_estimate;
  std::vector<Eigen::Vector3d> centres_true;
};

DriftingPoseGraph makeDriftingPoseGraph(const DriftingPoseGraphOptions& options);

/// Root mean square distance between the camera centres of `S_kf_world` (all ids 0..n-1) and
/// the true centres.
double centreRmse(const std::map<map::KeyframeId, geometry::Sim3>& S_kf_world,
                  const std::vector<Eigen::Vector3d>& centres_true);

}  // namespace scale_drift_slam::sim
