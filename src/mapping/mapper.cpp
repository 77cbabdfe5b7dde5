#include "scale_drift_slam/mapping/mapper.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <stdexcept>
#include <unordered_map>
#include <unordered_set>

#include "scale_drift_slam/common/stopwatch.h"
#include "scale_drift_slam/loop/map_correction.h"
#include "scale_drift_slam/loop/pose_graph_builder.h"

namespace scale_drift_slam::mapping {
namespace {

/// A point this many times farther from its reference keyframe than that keyframe's median point
/// depth has run away: its rays are (nearly) parallel, as for a point on a car driving with the
/// camera, and the bundle adjustments push it towards infinity (one at 2.7e7 map units made the
/// loop closer and the tracker refuse a whole loop correction on city_loop with traffic).
constexpr double kRunawayDepthRatio = 50.0;

double medianDepth(const map::Map& map, const map::Keyframe& keyframe) {
  std::vector<double> depths;
  depths.reserve(keyframe.observations.size());
  for (const map::Observation& o : keyframe.observations) {
    if (map.hasPoint(o.point_id))
      depths.push_back((keyframe.T_kf_world * map.point(o.point_id).p_world).z());
  }
  if (depths.empty()) return 0.0;
  std::nth_element(depths.begin(), depths.begin() + static_cast<long>(depths.size() / 2),
                   depths.end());
  return depths[depths.size() / 2];
}

/// Removes the points (ids in increasing order) from the map, takes them out of the update's
/// positions (the window BA may have moved some of them just now) and lists them as removed.
void removePoints(map::Map& map, const std::vector<map::PointId>& sorted_ids,
                  map::MapUpdate& update) {
  if (sorted_ids.empty()) return;
  for (const map::PointId id : sorted_ids)
    map.removePoint(id);
  auto removed = [&](const std::pair<map::PointId, Eigen::Vector3d>& entry) {
    return std::binary_search(sorted_ids.begin(), sorted_ids.end(), entry.first);
  };
  update.point_positions.erase(
      std::remove_if(update.point_positions.begin(), update.point_positions.end(), removed),
      update.point_positions.end());
  update.removed_points.insert(update.removed_points.end(), sorted_ids.begin(), sorted_ids.end());
}

/// Removes the run-away points among `ids` from the map and lists them in the update (the
/// tracker and the loop closer drop them too); their positions are taken out of the update.
/// A point is measured from its reference keyframe, or, where that one observes nothing (a culled
/// keyframe keeps its pose but no observations: median depth 0), from the first keyframe observing
/// it. Skipping those let a point 1.02e6 map units out into an update, which the tracker refused
/// whole, again at every update, while the point stayed in the window (test twohosts_outage).
void removeRunawayPoints(map::Map& map, const std::vector<map::PointId>& ids,
                         map::MapUpdate& update) {
  std::unordered_map<map::KeyframeId, double> median;
  auto medianOf = [&](const map::Keyframe& keyframe) {
    auto it = median.find(keyframe.id);
    if (it == median.end()) it = median.emplace(keyframe.id, medianDepth(map, keyframe)).first;
    return it->second;
  };
  std::vector<map::PointId> runaway;
  for (const map::PointId id : ids) {
    if (!map.hasPoint(id)) continue;
    const map::MapPoint& point = map.point(id);
    std::vector<map::KeyframeId> measured_from{point.reference_keyframe};
    measured_from.insert(measured_from.end(), point.observed_by.begin(), point.observed_by.end());
    for (const map::KeyframeId kf_id : measured_from) {
      if (!map.hasKeyframe(kf_id)) continue;
      const map::Keyframe& keyframe = map.keyframe(kf_id);
      const double scene_depth = medianOf(keyframe);
      if (!(scene_depth > 0.0)) continue;
      if ((keyframe.T_kf_world * point.p_world).norm() > kRunawayDepthRatio * scene_depth)
        runaway.push_back(id);
      break;
    }
  }
  std::sort(runaway.begin(), runaway.end());
  removePoints(map, runaway, update);
}

}  // namespace

std::string LoopCorrectionStatistics::describe() const {
  char text[480];
  const std::string loop =
      "loop " + std::to_string(constraint.current_id) + " -> " + std::to_string(constraint.loop_id);
  if (!applied) return loop + " not applied: " + reason;
  std::snprintf(text, sizeof(text),
                " corrected: %s graph of %zu keyframes (%zu co-visibility, %zu loop edges), %d "
                "iterations%s; times: build %.1f ms, solve %.1f ms, map %.1f ms, structure-only "
                "BA %.1f ms (%zu of %zu points), total %.1f ms; scale at the current keyframe %.4f",
                loop::toString(mode).c_str(), vertices, covisibility_edges, loop_edges,
                graph_iterations, graph_converged ? "" : " (not converged)", build_ms, graph_ms,
                correction_ms, structure_ms, structure_points, map_points, total_ms,
                current_correction_scale);
  return loop + text;
}

void LoopCorrectionParams::validate() const {
  graph.validate();
  structure.validate();
  if (covisibility_min_shared_points < 0 || covisibility_max_edges < 0) {
    throw std::invalid_argument(
        "loop correction: covisibility_min_shared_points and covisibility_max_edges must be >= 0");
  }
  if (!(structure_min_shift_px >= 0.0) || !std::isfinite(structure_min_shift_px)) {
    throw std::invalid_argument("loop correction: structure_min_shift_px must be finite and >= 0");
  }
  if (!(loop_edge_weight > 0.0)) {
    throw std::invalid_argument("loop correction: loop_edge_weight must be > 0");
  }
}

void MapperParams::validate() const {
  window.validate();
  point_culling.validate();
  keyframe_culling.validate();
  loop_correction.validate();
}

Mapper::Mapper(const MapperParams& params, double focal_length_px)
    : params_(params), focal_length_px_(focal_length_px) {
  params_.validate();
  if (!(focal_length_px_ > 0.0))
    throw std::invalid_argument("mapper needs a positive focal length");
}

Mapper::Mapper(const MapperParams& params, double focal_length_px, map::Map map,
               std::vector<loop::PoseGraphEdge> loop_edges)
    : Mapper(params, focal_length_px) {
  map_ = std::move(map);
  loop_edges_ = std::move(loop_edges);
}

map::MapUpdate Mapper::addKeyframe(map::KeyframeMessage message,
                                   features::BundleStatistics* statistics) {
  corrections_.bringUpToDate(message);
  map::addKeyframeMessage(message, map_);

  map::MapUpdate update;
  if (statistics) *statistics = features::BundleStatistics{};
  const bool enough = static_cast<int>(map_.numKeyframes()) > params_.window.num_fixed_keyframes;
  if (params_.run_window_ba && enough) {
    const WindowBundleInput input = makeWindowInput(map_, params_.window, focal_length_px_);
    const WindowBundleResult result = solveWindowBundleAdjustment(input, params_.window);
    applyWindowResult(result, map_);
    if (statistics) *statistics = result.statistics;
    for (const BundleKeyframe& kf : result.keyframes) {
      if (!kf.fixed) update.keyframe_poses.emplace_back(kf.id, kf.T_kf_world);
    }
    std::vector<map::PointId> moved;
    for (const BundlePoint& p : result.points) {
      if (p.fixed) continue;
      update.point_positions.emplace_back(p.id, p.p_world);
      moved.push_back(p.id);
    }
    removeRunawayPoints(map_, moved, update);
  }
  cullWeakPoints(update);
  cullRedundantKeyframe(update);
  update.map_version = map_.version();
  return update;
}

void Mapper::cullWeakPoints(map::MapUpdate& update) {
  const std::vector<map::PointId> weak = weakPoints(map_, params_.point_culling);
  removePoints(map_, weak, update);
  culled_points_ += weak.size();
}

void Mapper::cullRedundantKeyframe(map::MapUpdate& update) {
  std::unordered_set<map::KeyframeId> loop_ends;
  for (const loop::PoseGraphEdge& edge : loop_edges_) {
    loop_ends.insert(edge.from);
    loop_ends.insert(edge.to);
  }
  const std::optional<map::KeyframeId> redundant =
      redundantKeyframe(map_, params_.window.window_size, params_.keyframe_culling, loop_ends);
  if (!redundant) return;
  std::vector<map::PointId> orphans;
  for (const map::PointId id : map_.clearObservations(*redundant)) {
    if (map_.point(id).observed_by.size() < 2) orphans.push_back(id);
  }
  removePoints(map_, orphans, update);  // sorted: clearObservations returns increasing ids
  update.culled_keyframes.push_back(*redundant);
  ++culled_keyframes_;
}

map::MapUpdate Mapper::closeLoop(const loop::LoopConstraint& constraint,
                                 LoopCorrectionStatistics* statistics) {
  const common::Stopwatch timer;
  const double cpu_start = common::threadCpuMs();
  LoopCorrectionStatistics stats;
  stats.constraint = constraint;
  stats.mode = params_.loop_correction.graph.mode;
  for (const map::KeyframeId id : {constraint.current_id, constraint.loop_id}) {
    if (!map_.hasKeyframe(id)) {
      stats.reason = "the map holds no keyframe " + std::to_string(id);
      if (statistics) *statistics = stats;
      return {};
    }
  }
  for (const auto& [id, keyframe] : map_.keyframes())
    stats.keyframes_before.emplace_back(keyframe.timestamp, keyframe.T_kf_world);
  // The earlier loops and this one; kept for later graphs only once the graph is solved (a graph
  // that cannot be built or solved throws and must not poison the next loops).
  std::vector<loop::PoseGraphEdge> loop_edges = loop_edges_;
  loop_edges.push_back(loopEdge(constraint));
  const loop::PoseGraphResult solved = solveLoopGraph(loop_edges, &stats);
  stats.current_correction_scale = solved.S_kf_world.at(constraint.current_id).scale();
  loop_edges_ = std::move(loop_edges);
  map::MapUpdate update = correctMap(solved, &stats);
  for (const loop::PoseGraphEdge& loop_edge : loop_edges_)
    update.loop_links.emplace_back(loop_edge.from, loop_edge.to);
  corrections_.record(update);
  stats.applied = true;
  stats.total_ms = timer.ms();
  stats.total_cpu_ms = common::threadCpuMs() - cpu_start;
  if (statistics) *statistics = stats;
  return update;
}

loop::PoseGraphEdge Mapper::loopEdge(const loop::LoopConstraint& constraint) const {
  loop::PoseGraphEdge edge;
  edge.from = constraint.current_id;
  edge.to = constraint.loop_id;
  edge.S_from_to = constraint.S_current_loop;
  edge.information *= params_.loop_correction.loop_edge_weight;
  edge.kind = loop::EdgeKind::kLoop;
  return edge;
}

loop::PoseGraphResult Mapper::solveLoopGraph(const std::vector<loop::PoseGraphEdge>& loop_edges,
                                             LoopCorrectionStatistics* stats) const {
  const common::Stopwatch timer;
  const LoopCorrectionParams& p = params_.loop_correction;
  // The graph over all keyframes, the oldest fixed (it defines the world frame).
  loop::PoseGraphBuilderOptions builder;
  builder.min_shared_points = p.covisibility_min_shared_points;
  builder.max_covisibility_edges_per_keyframe = p.covisibility_max_edges;
  const map::KeyframeId oldest = map_.keyframes().begin()->first;
  const loop::PoseGraph graph = loop::buildPoseGraph(map_, {}, loop_edges, {oldest}, builder);
  stats->build_ms = timer.ms();
  stats->vertices = graph.vertices().size();
  stats->loop_edges = graph.numEdges(loop::EdgeKind::kLoop);
  stats->covisibility_edges = graph.numEdges(loop::EdgeKind::kCovisibility);
  loop::PoseGraphResult solved = graph.optimize(p.graph);
  stats->graph_iterations = solved.iterations;
  stats->graph_converged = solved.converged;
  stats->graph_initial_chi2 = solved.initial_chi2;
  stats->graph_guess_loops = solved.guess_loops;
  stats->graph_guess_chi2 = solved.guess_chi2;
  stats->graph_final_chi2 = solved.final_chi2;
  stats->graph_ms = 1e3 * solved.time_s;
  return solved;
}

std::vector<map::PointId> Mapper::refineDisturbedStructure(
    const std::vector<std::pair<map::KeyframeId, geometry::Sim3>>& corrections,
    LoopCorrectionStatistics* stats) {
  const common::Stopwatch timer;
  const LoopCorrectionParams& p = params_.loop_correction;
  stats->map_points = map_.numPoints();
  std::vector<map::PointId> points;
  if (p.structure_min_shift_px > 0.0) {
    points = loop::pointsDisturbedByCorrection(map_, corrections, focal_length_px_,
                                               p.structure_min_shift_px);
    stats->structure_selection_ms = timer.ms();
    if (points.empty()) {
      stats->structure_ms = timer.ms();
      return points;
    }
  } else {
    points.reserve(map_.numPoints());
    for (const auto& entry : map_.points())
      points.push_back(entry.first);
  }
  auto distance = [&](map::PointId id) {  // from the point's reference keyframe
    const map::MapPoint& point = map_.point(id);
    return map_.hasKeyframe(point.reference_keyframe)
               ? (map_.keyframe(point.reference_keyframe).T_kf_world * point.p_world).norm()
               : 0.0;
  };
  std::vector<double> before(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    before[i] = distance(points[i]);
  const StructureOnlyBAResult structure =
      refineStructure(map_, points, {focal_length_px_, focal_length_px_}, p.structure);
  stats->structure_points = structure.points + structure.points_skipped;
  stats->reprojection_before = structure.before;  // after the correction, before the refinement
  stats->reprojection_after = structure.after;
  // Run-away points are pushed outwards by the BA; the others moved with their reference keyframe
  // and kept their distance from it, up to a factor kPushedOut.
  constexpr double kPushedOut = 1.5;
  std::vector<map::PointId> pushed;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (distance(points[i]) > kPushedOut * before[i]) pushed.push_back(points[i]);
  }
  stats->structure_ms = timer.ms();
  return pushed;
}

map::MapUpdate Mapper::correctMap(const loop::PoseGraphResult& solved,
                                  LoopCorrectionStatistics* stats) {
  map::MapUpdate update;
  // C_k = S_k_new^-1 T_k_old maps old world coordinates near keyframe k into corrected ones.
  for (const auto& [id, S_kf_world] : solved.S_kf_world) {
    update.keyframe_corrections.emplace_back(
        id, S_kf_world.inverse() * geometry::Sim3(map_.keyframe(id).T_kf_world));
  }
  update.S_new_old = update.keyframe_corrections.back().second;  // the newest keyframe's
  const common::Stopwatch correction_timer;
  loop::applyPoseGraphCorrection(map_, solved.S_kf_world);
  stats->correction_ms = correction_timer.ms();
  const std::vector<map::PointId> pushed =
      refineDisturbedStructure(update.keyframe_corrections, stats);

  for (const auto& [id, keyframe] : map_.keyframes())
    update.keyframe_poses.emplace_back(id, keyframe.T_kf_world);
  update.point_positions.reserve(map_.numPoints());
  for (const auto& [id, point] : map_.points())
    update.point_positions.emplace_back(id, point.p_world);
  // A point the BA did not push outwards moved with its reference keyframe and kept its depth
  // there (relative to the keyframe's median): it was no run-away before the loop (the window BA
  // removes them), it is none now, except one already beyond 50 / 1.5 = 33 median depths.
  removeRunawayPoints(map_, pushed, update);
  map_.bumpVersion();
  update.map_version = map_.version();
  return update;
}

}  // namespace scale_drift_slam::mapping
