#pragma once
// Loop constraints of a simulated visual-odometry run, measured from the observations (never from
// the truth): the simulation gives the data association (which old map point a feature of the
// current keyframe images); the constraint itself comes from loop::estimateLoopConstraint on the
// estimated map, exactly as with real features (paper/ALGORITHM.md, "Loop closure detection").
// Pure functions of a finished run.

#include <cstddef>
#include <vector>

#include "scale_drift_slam/loop/loop_constraint.h"
#include "scale_drift_slam/sim/simulated_visual_odometry.h"

namespace scale_drift_slam::sim {

struct LoopDetectionParams {
  int min_shared_points = 25;   ///< Old map points the current keyframe must see again.
  int min_keyframe_gap = 40;    ///< The loop keyframe is at least this many keyframes older.
  int cooldown_keyframes = 60;  ///< After a loop, skip this many keyframes before the next.
  loop::LoopConstraintParams constraint;
  /// Throws std::invalid_argument naming the first bad value.
  void validate() const;
};

/// The constraint between keyframes `current` and `loop` (indices into vo.keyframes()):
/// 2D-3D matches = features of `current` whose point `loop` observes in the map (in `loop`'s
/// camera frame); 3D-3D pairs = those points that `current` also observes as its own map points.
loop::LoopConstraintResult measureLoop(const SimulatedVisualOdometry& vo, std::size_t current,
                                       std::size_t loop, double focal_length_px,
                                       const loop::LoopConstraintParams& params);

/// Loop detection over a finished run: for each keyframe (in order), the older keyframe that
/// observes the most map points the current keyframe sees again (a vote per shared point); a
/// candidate with enough votes is verified by measureLoop. Returns the accepted constraints.
std::vector<loop::LoopConstraint> detectLoops(const SimulatedVisualOdometry& vo,
                                              double focal_length_px,
                                              const LoopDetectionParams& params);

}  // namespace scale_drift_slam::sim
