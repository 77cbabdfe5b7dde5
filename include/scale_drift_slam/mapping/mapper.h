#pragma once
// The back-end's owner of the global map (doc/algorithm.md, "Back-end: sliding-window bundle
// adjustment" and "Loop closure correction"): takes the tracker's keyframe messages, adds
// keyframes, new points and their observations to the map, runs the sliding-window BA
// (window_bundle_adjustment.h) and returns the corrections as a map::MapUpdate for the tracker.
// A verified loop constraint from the loop closer is applied by closeLoop: the Sim(3) (or, for
// comparison, SE(3)) pose graph over all keyframes, the point correction through the reference
// keyframes and a structure-only BA. Runs on the mapping thread (offline) or in the mapping node;
// owns the map::Map; nothing else writes to it.

#include <cstdint>
#include <string>
#include <vector>

#include "scale_drift_slam/loop/loop_constraint.h"
#include "scale_drift_slam/loop/pose_graph.h"
#include "scale_drift_slam/map/keyframe_message.h"
#include "scale_drift_slam/map/map.h"
#include "scale_drift_slam/map/map_update.h"
#include "scale_drift_slam/mapping/keyframe_culling.h"
#include "scale_drift_slam/mapping/point_culling.h"
#include "scale_drift_slam/mapping/structure_only_ba.h"
#include "scale_drift_slam/mapping/window_bundle_adjustment.h"

namespace scale_drift_slam::mapping {

/// How a loop constraint corrects the map.
struct LoopCorrectionParams {
  /// The graph's mode (sim3: the paper; se3: the baseline that cannot correct scale) and solver.
  /// LM stops when chi2 changes by less than 1e-6 relatively: centimetre-level agreement with
  /// the fully converged graph for a fraction of the iterations (doc/loop_closure.md). LM starts
  /// with damping 1e-10, nearly Gauss-Newton: on the 2312-keyframe city_tour graph the
  /// PoseGraphOptions default 1e-6 (times diag(J^T J)) held back the loop's weak bending modes and
  /// took 7 iterations where 1e-10 takes 2, to the same optimum (doc/benchmarks.md, "Loop
  /// correction time"); a step that fails raises the damping as before.
  loop::PoseGraphOptions graph = sixDigits();
  static loop::PoseGraphOptions sixDigits() {
    loop::PoseGraphOptions options;
    options.function_tolerance = 1e-6;
    options.initial_damping = 1e-10;
    return options;
  }
  /// Co-visibility edges join keyframes sharing at least this many points (0: none), at most
  /// `covisibility_max_edges` from each keyframe (the strongest): ORB-SLAM's essential graph.
  int covisibility_min_shared_points = 100;
  int covisibility_max_edges = 3;
  /// Weight of a loop edge's information relative to an odometry edge's (identity).
  double loop_edge_weight = 1.0;
  StructureOnlyBAOptions structure;
  /// The structure-only BA refines only the points whose image in one of their observers the
  /// correction moved by more than this many pixels (loop::pointsDisturbedByCorrection: where the
  /// correction is not smooth); the others move with their reference keyframe and keep their
  /// reprojection errors to within this. 0: every point of the map (the earlier behaviour).
  double structure_min_shift_px = 0.25;
  /// Throws std::invalid_argument naming the first bad value.
  void validate() const;
};

struct MapperParams {
  WindowBundleAdjustmentParams window;
  bool run_window_ba = true;  ///< Off: keyframes are only collected (for tests and debugging).
  PointCullingParams point_culling;
  KeyframeCullingParams keyframe_culling;
  LoopCorrectionParams loop_correction;
  void validate() const;
};

/// What one loop correction did.
struct LoopCorrectionStatistics {
  bool applied = false;
  std::string reason;  ///< Why not, when not applied.
  loop::LoopConstraint constraint;
  std::size_t vertices = 0, loop_edges = 0, covisibility_edges = 0;
  int graph_iterations = 0;
  bool graph_converged = false;  ///< False: LM stopped at its iteration limit (still applied).
  double graph_initial_chi2 = 0.0, graph_final_chi2 = 0.0;
  /// Where LM started: the loop errors of graph_guess_loops loop edges distributed (0: the map's
  /// poses, chi2 graph_initial_chi2).
  int graph_guess_loops = 0;
  double graph_guess_chi2 = 0.0;
  /// Scale of the correction at the current keyframe (1 for SE(3)).
  double current_correction_scale = 1.0;
  /// Every keyframe's stamp and T_kf_world just before the correction: the map whose drift the
  /// loop measured (after an earlier correction, the trajectory as tracked is not that map).
  std::vector<std::pair<double, geometry::SE3>> keyframes_before;
  /// Building the graph, solving it, moving keyframes and points, structure-only BA, the whole.
  /// structure_ms includes choosing the points to refine (loop::pointsDisturbedByCorrection).
  double build_ms = 0.0, graph_ms = 0.0, correction_ms = 0.0, structure_ms = 0.0, total_ms = 0.0;
  /// Points the structure-only BA refined, of all points of the map.
  std::size_t structure_points = 0, map_points = 0;
  double structure_selection_ms = 0.0;  ///< Choosing them (part of structure_ms).
  /// The whole correction's CPU time on the mapping thread (unaffected by other processes).
  double total_cpu_ms = 0.0;
  /// Reprojection errors of the refined points after the correction, before and after the
  /// structure-only BA.
  ReprojectionStats reprojection_before, reprojection_after;
  loop::PoseGraphMode mode = loop::PoseGraphMode::kSim3;
  /// One line for logs: the loop, the graph and the time of each step, or why it was refused.
  std::string describe() const;
};

class Mapper {
 public:
  Mapper(const MapperParams& params, double focal_length_px);
  /// Goes on with a saved map and the loop edges applied to it (system/map_snapshot.h).
  Mapper(const MapperParams& params, double focal_length_px, map::Map map,
         std::vector<loop::PoseGraphEdge> loop_edges);

  /// Adds the keyframe (brought into the current world frame when it was made before a loop
  /// correction; observations of points the map does not know are skipped), runs the window BA
  /// and returns the correction of the window's poses and points. `statistics`, when given,
  /// receives the BA's figures (time_ms = 0 when it did not run).
  map::MapUpdate addKeyframe(map::KeyframeMessage message,
                             features::BundleStatistics* statistics = nullptr);

  /// Applies a verified loop constraint: the pose graph over all keyframes (consecutive and
  /// co-visibility edges from the current estimates, every loop edge so far), the point and
  /// keyframe correction, structure-only BA. Returns the update for the tracker and the loop
  /// closer (every pose and point, the per-keyframe corrections). A constraint naming a keyframe
  /// the map does not hold is not applied (statistics->reason; the update is then empty).
  map::MapUpdate closeLoop(const loop::LoopConstraint& constraint,
                           LoopCorrectionStatistics* statistics = nullptr);

  const map::Map& map() const { return map_; }
  const std::vector<loop::PoseGraphEdge>& loopEdges() const { return loop_edges_; }
  /// Weak points culled so far (point_culling).
  std::size_t culledPoints() const { return culled_points_; }
  /// Redundant keyframes culled so far (keyframe_culling).
  std::size_t culledKeyframes() const { return culled_keyframes_; }

 private:
  /// Removes the weak points (point_culling.h) from the map and lists them in the update.
  void cullWeakPoints(map::MapUpdate& update);
  /// Culls the redundant keyframe (keyframe_culling.h), if any, and the points it leaves seen by
  /// fewer than two keyframes, and lists them in the update.
  void cullRedundantKeyframe(map::MapUpdate& update);
  /// The loop edge of a constraint, weighted by loop_correction.loop_edge_weight.
  loop::PoseGraphEdge loopEdge(const loop::LoopConstraint& constraint) const;
  /// Builds the pose graph over all keyframes with these loop edges and solves it; throws
  /// what the builder or the solver throw.
  loop::PoseGraphResult solveLoopGraph(const std::vector<loop::PoseGraphEdge>& loop_edges,
                                       LoopCorrectionStatistics* stats) const;
  /// Moves keyframes and points with the solved graph, refines the points (structure-only BA)
  /// and returns the update for the tracker.
  map::MapUpdate correctMap(const loop::PoseGraphResult& solved, LoopCorrectionStatistics* stats);
  /// The structure-only BA after the correction, over the points it disturbed (or all, see
  /// LoopCorrectionParams::structure_min_shift_px); returns the points it pushed outwards by
  /// more than half their distance from their reference keyframe (run-away candidates).
  std::vector<map::PointId> refineDisturbedStructure(
      const std::vector<std::pair<map::KeyframeId, geometry::Sim3>>& corrections,
      LoopCorrectionStatistics* stats);

  MapperParams params_;
  double focal_length_px_;
  map::Map map_;
  std::vector<loop::PoseGraphEdge> loop_edges_;
  map::CorrectionHistory corrections_;
  std::size_t culled_points_ = 0;
  std::size_t culled_keyframes_ = 0;
};

}  // namespace scale_drift_slam::mapping
