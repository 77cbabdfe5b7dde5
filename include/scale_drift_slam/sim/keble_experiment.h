#pragma once
// The paper's real-data experiment (Figure 2): loop closure on the Keble College keyframe map,
// corrected once with an SE(3) and once with a Sim(3) pose graph. The graph is built as the
// authors built it (test/data/keble_college/README.md): vertices = keyframes loop..last, the
// loop keyframe fixed, consecutive edges T_i T_{i-1}^-1 with identity information, and one loop
// edge last -> loop measured as T_loop T_current^-1 with relative scale 1 / Scale (Sim(3)) or
// rigid (SE(3)). Each solution then corrects the map (loop/map_correction.h) and structure-only
// BA refines the points (mapping/structure_only_ba.h).

#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "scale_drift_slam/io/keble_map.h"
#include "scale_drift_slam/loop/pose_graph.h"
#include "scale_drift_slam/mapping/structure_only_ba.h"

namespace scale_drift_slam::sim {

struct KebleExperimentOptions {
  /// Solver settings shared by both variants (the mode is set per variant).
  loop::PoseGraphOptions graph;
  mapping::StructureOnlyBAOptions structure;
  /// Also join keyframes sharing at least this many points (0: none, as the authors did).
  int min_shared_points = 0;

  /// Throws std::invalid_argument naming the offending field.
  void validate() const;
};

/// One correction variant (SE(3) or Sim(3)).
struct KebleVariant {
  std::string name;  ///< "se3" or "sim3".
  loop::PoseGraphResult graph;
  mapping::ReprojectionStats after_correction;  ///< Before structure-only BA.
  mapping::StructureOnlyBAResult structure;
  map::Map map;                          ///< Corrected, after structure-only BA.
  std::vector<Eigen::Vector3d> centres;  ///< Camera centres of keyframes 0..n-1.
  double path_length = 0.0;              ///< Along the loop (loop keyframe .. last).
  /// Distance between the last keyframe's corrected centre and where the loop edge, applied to
  /// the corrected loop keyframe, puts it.
  double loop_gap = 0.0;
  double last_keyframe_scale = 1.0;  ///< Solved scale of the last keyframe's vertex.
};

struct KebleExperimentResult {
  map::KeyframeId loop_keyframe = 0;
  map::KeyframeId last_keyframe = 0;
  std::size_t vertices = 0;
  std::size_t consecutive_edges = 0;
  std::size_t covisibility_edges = 0;
  std::size_t loop_edges = 0;
  std::vector<Eigen::Vector3d> centres_before;
  double path_length_before = 0.0;
  double loop_gap_before = 0.0;
  mapping::ReprojectionStats reprojection_before;
  KebleVariant se3;
  KebleVariant sim3;
};

/// The pose graph of the experiment (see the file comment).
loop::PoseGraph makeKeblePoseGraph(const io::KebleMap& keble, int min_shared_points);

/// Runs both variants. Throws std::invalid_argument for invalid options.
KebleExperimentResult runKebleExperiment(const io::KebleMap& keble,
                                         const KebleExperimentOptions& options);

/// The machine-readable summary (written as summary.json).
nlohmann::json kebleSummary(const KebleExperimentResult& result, const io::KebleMap& keble);

/// Writes into `out_dir` (created when missing): before.tum, se3.tum, sim3.tum (keyframe camera
/// poses T_world_cam, timestamp = keyframe index), se3_points.txt and sim3_points.txt (corrected
/// points "id x y z"), keble_top_view.png (x-z plane) and summary.json. Throws
/// std::runtime_error when a file cannot be written.
void writeKebleExperiment(const KebleExperimentResult& result, const io::KebleMap& keble,
                          const std::string& out_dir);

}  // namespace scale_drift_slam::sim
