#pragma once
// Loop constraints of a simulated visual-odometry run, measured from the observations (never from
// the truth): the simulation gives the data association (which old map point a feature of the
// current keyframe images); the constraint itself comes from loop::estimateLoopConstraint on the
// estimated map, exactly as with real features (doc/algorithm.md, "Loop closure detection").
// The points of each keyframe are first re-triangulated from the keyframes around it (poses
// fixed): a sliding-window map keeps refining a point after an old keyframe has left the window,
// so the map positions drift away from what the old keyframe saw (several pixels), while its
// neighbourhood's observations give the local structure the paper's loop step assumes.
// Pure functions of a finished run.

#include <cstddef>
#include <unordered_map>
#include <vector>

#include "scale_drift_slam/loop/loop_constraint.h"
#include "scale_drift_slam/sim/simulated_visual_odometry.h"

namespace scale_drift_slam::sim {

struct LoopMeasurementParams {
  loop::LoopConstraintParams constraint;
  /// Re-triangulate each keyframe's points from its observations in the keyframes at most this
  /// many before or after it (structure-only BA, poses fixed); 0 uses the map positions as they
  /// are.
  int structure_keyframes = 4;
  /// A matched feature whose point the current keyframe does not hold gets its depth from the
  /// median of its nearest this many points of the current keyframe, within depth_radius_px.
  int depth_neighbours = 3;
  double depth_radius_px = 20.0;
  /// Throws std::invalid_argument naming the first bad value.
  void validate() const;
};

struct LoopDetectionParams {
  int min_shared_points = 25;   ///< Old map points the current keyframe must see again.
  int min_keyframe_gap = 40;    ///< The loop keyframe is at least this many keyframes older.
  int cooldown_keyframes = 60;  ///< After a loop, skip this many keyframes before the next.
  LoopMeasurementParams measurement;
  /// Throws std::invalid_argument naming the first bad value.
  void validate() const;
};

/// The constraint between keyframes `current` and `loop` (indices into vo.keyframes()):
/// 2D-3D matches = features of `current` whose point `loop` observes in the map (in `loop`'s
/// camera frame); 3D-3D pairs = those points as `current` holds them, or, where it does not hold
/// one, the feature at the depth its neighbours in `current` give (k-nearest-neighbour regression).
loop::LoopConstraintResult measureLoop(const SimulatedVisualOdometry& vo, std::size_t current,
                                       std::size_t loop, double focal_length_px,
                                       const LoopMeasurementParams& params);

/// The points keyframe `k` observes, by simulated point id, in k's camera frame: re-triangulated
/// from their observations in keyframes k - radius .. k + radius (map positions where a point has
/// fewer than two such observations, or radius = 0).
std::unordered_map<int, Eigen::Vector3d> localStructure(const SimulatedVisualOdometry& vo,
                                                        std::size_t k, int radius,
                                                        double focal_length_px);

/// Loop detection over a finished run: for each keyframe (in order), the older keyframe that
/// observes the most map points the current keyframe sees again (a vote per shared point); a
/// candidate with enough votes is verified by measureLoop. Returns the accepted constraints.
std::vector<loop::LoopConstraint> detectLoops(const SimulatedVisualOdometry& vo,
                                              double focal_length_px,
                                              const LoopDetectionParams& params);

}  // namespace scale_drift_slam::sim
