#include "scale_drift_slam/sim/keble_experiment.h"

#include <stdexcept>

#include "scale_drift_slam/loop/map_correction.h"
#include "scale_drift_slam/loop/pose_graph_builder.h"

namespace scale_drift_slam::sim {
namespace {

using geometry::Sim3;

std::vector<map::KeyframeId> loopKeyframes(const io::KebleMap& keble) {
  std::vector<map::KeyframeId> ids;
  for (const auto& entry : keble.map.keyframes()) {
    if (entry.first >= keble.loop_keyframe) {
      ids.push_back(entry.first);
    }
  }
  return ids;
}

map::KeyframeId lastKeyframe(const io::KebleMap& keble) {
  return keble.map.keyframes().rbegin()->first;
}

/// The loop edge last -> loop keyframe of the authors: S = T_loop T_current^-1 with scale
/// 1 / Scale (for SE(3) the graph drops the scale itself).
loop::PoseGraphEdge loopEdge(const io::KebleMap& keble) {
  loop::PoseGraphEdge edge;
  edge.from = keble.loop_keyframe;
  edge.to = lastKeyframe(keble);
  edge.S_from_to = loop::similarityWithScale(
      keble.map.keyframe(keble.loop_keyframe).T_kf_world * keble.T_current_world.inverse(),
      1.0 / keble.loop_scale);
  edge.kind = loop::EdgeKind::kLoop;
  return edge;
}

std::vector<Eigen::Vector3d> centresOf(const map::Map& map) {
  std::vector<Eigen::Vector3d> centres;
  for (const auto& entry : map.keyframes()) {
    centres.push_back(entry.second.T_kf_world.inverseTranslation());
  }
  return centres;
}

double pathLength(const std::vector<Eigen::Vector3d>& centres, std::size_t first) {
  double length = 0.0;
  for (std::size_t i = first + 1; i < centres.size(); ++i) {
    length += (centres[i] - centres[i - 1]).norm();
  }
  return length;
}

/// |centre(S_to) - centre(S_from_to^-1 S_from)|: how far the edge's measurement is from closing.
double loopGap(const loop::PoseGraphEdge& edge, const Sim3& S_from, const Sim3& S_to,
               loop::PoseGraphMode mode) {
  const Sim3 measurement =
      mode == loop::PoseGraphMode::kSim3 ? edge.S_from_to : Sim3(loop::dropScale(edge.S_from_to));
  const Sim3 S_to_predicted = measurement.inverse() * S_from;
  return (loop::cameraCentre(S_to) - loop::cameraCentre(S_to_predicted)).norm();
}

KebleVariant runVariant(const io::KebleMap& keble, const loop::PoseGraph& graph,
                        loop::PoseGraphMode mode, const KebleExperimentOptions& options) {
  KebleVariant variant;
  variant.name = loop::toString(mode);
  loop::PoseGraphOptions graph_options = options.graph;
  graph_options.mode = mode;
  variant.graph = graph.optimize(graph_options);
  variant.map = keble.map;
  loop::applyPoseGraphCorrection(variant.map, variant.graph.S_kf_world);
  variant.after_correction = mapping::reprojectionStats(variant.map, keble.camera.focalLength());
  variant.structure =
      mapping::refineStructure(variant.map, {}, keble.camera.focalLength(), options.structure);
  variant.centres = centresOf(variant.map);
  variant.path_length = pathLength(variant.centres, keble.loop_keyframe);
  const loop::PoseGraphEdge edge = loopEdge(keble);
  variant.loop_gap = loopGap(edge, variant.graph.S_kf_world.at(edge.from),
                             variant.graph.S_kf_world.at(edge.to), mode);
  variant.last_keyframe_scale = variant.graph.S_kf_world.at(edge.to).scale();
  return variant;
}

}  // namespace

void KebleExperimentOptions::validate() const {
  graph.validate();
  structure.validate();
  if (min_shared_points < 0) {
    throw std::invalid_argument("Keble experiment: min_shared_points must be >= 0");
  }
}

loop::PoseGraph makeKeblePoseGraph(const io::KebleMap& keble, int min_shared_points) {
  loop::PoseGraphBuilderOptions builder;
  builder.min_shared_points = min_shared_points;
  return loop::buildPoseGraph(keble.map, loopKeyframes(keble), {loopEdge(keble)},
                              {keble.loop_keyframe}, builder);
}

KebleExperimentResult runKebleExperiment(const io::KebleMap& keble,
                                         const KebleExperimentOptions& options) {
  options.validate();
  const loop::PoseGraph graph = makeKeblePoseGraph(keble, options.min_shared_points);
  KebleExperimentResult result;
  result.loop_keyframe = keble.loop_keyframe;
  result.last_keyframe = lastKeyframe(keble);
  result.vertices = graph.vertices().size();
  result.consecutive_edges = graph.numEdges(loop::EdgeKind::kConsecutive);
  result.covisibility_edges = graph.numEdges(loop::EdgeKind::kCovisibility);
  result.loop_edges = graph.numEdges(loop::EdgeKind::kLoop);
  result.centres_before = centresOf(keble.map);
  result.path_length_before = pathLength(result.centres_before, keble.loop_keyframe);
  const loop::PoseGraphEdge edge = loopEdge(keble);
  result.loop_gap_before =
      loopGap(edge, graph.vertices().at(edge.from).S_kf_world,
              graph.vertices().at(edge.to).S_kf_world, loop::PoseGraphMode::kSim3);
  result.reprojection_before = mapping::reprojectionStats(keble.map, keble.camera.focalLength());
  result.se3 = runVariant(keble, graph, loop::PoseGraphMode::kSE3, options);
  result.sim3 = runVariant(keble, graph, loop::PoseGraphMode::kSim3, options);
  return result;
}

}  // namespace scale_drift_slam::sim
