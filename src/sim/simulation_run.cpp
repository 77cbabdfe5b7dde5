#include "scale_drift_slam/sim/simulation_run.h"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <limits>
#include <stdexcept>
#include <string>

#include "scale_drift_slam/common/statistics.h"
#include "scale_drift_slam/common/stopwatch.h"
#include "scale_drift_slam/loop/pose_graph_builder.h"

namespace scale_drift_slam::sim {
namespace {

CorrectedTrajectory solveVariant(const SimulatedVisualOdometry& vo, const loop::PoseGraph& graph,
                                 loop::PoseGraphMode mode, const CorrectionOptions& options,
                                 const std::vector<geometry::SE3>& T_world_cam_truth) {
  CorrectedTrajectory variant;
  variant.name = loop::toString(mode);
  loop::PoseGraphOptions graph_options = options.graph;
  graph_options.mode = mode;
  variant.graph = graph.optimize(graph_options);
  variant.T_world_cam = correctedFramePoses(vo, variant.graph.S_kf_world);
  variant.error = evaluation::firstPoseAlignedError(variant.T_world_cam, T_world_cam_truth);
  return variant;
}

}  // namespace

void CorrectionOptions::validate() const {
  graph.validate();
  auto fail = [](const std::string& what) { throw std::invalid_argument("correction: " + what); };
  if (covisibility_min_shared_points < 0) fail("covisibility_min_shared_points must be >= 0");
  if (!(odometry_information > 0.0) || !std::isfinite(odometry_information)) {
    fail("odometry_information must be positive and finite");
  }
  if (!(loop_information > 0.0) || !std::isfinite(loop_information)) {
    fail("loop_information must be positive and finite");
  }
}

double localMapScale(const SimulatedVisualOdometry& vo, const SimulatedWorld& world,
                     std::size_t k) {
  const KeyframeRecord& record = vo.keyframes().at(k);
  const map::Keyframe& kf = vo.map().keyframe(record.id);
  const geometry::SE3& T_true = world.T_cam_world.at(record.frame);
  std::vector<double> ratios;
  for (const map::Observation& o : kf.observations) {
    const double estimated = (kf.T_kf_world * vo.map().point(o.point_id).p_world).norm();
    const double truth = (T_true * world.points.at(vo.simPointOf(o.point_id))).norm();
    if (truth > 0.0) ratios.push_back(estimated / truth);
  }
  if (ratios.empty()) return std::numeric_limits<double>::quiet_NaN();
  return common::upperMedian(std::move(ratios));
}

LoopRecord makeLoopRecord(const SimulatedVisualOdometry& vo, const SimulatedWorld& world,
                          const loop::LoopConstraint& constraint) {
  LoopRecord record;
  // Keyframe ids are the indices into keyframes() (SimulatedVisualOdometry numbers them so).
  record.current_keyframe = constraint.current_id;
  record.loop_keyframe = constraint.loop_id;
  record.current_frame = vo.keyframes().at(record.current_keyframe).frame;
  record.loop_frame = vo.keyframes().at(record.loop_keyframe).frame;
  record.measured_scale = constraint.scale;
  record.true_scale = localMapScale(vo, world, record.current_keyframe) /
                      localMapScale(vo, world, record.loop_keyframe);
  record.inliers = constraint.num_inliers;
  record.scale_pairs = constraint.num_scale_pairs;
  record.rmse_px = constraint.rmse_px;
  return record;
}

loop::PoseGraph makeRunPoseGraph(const SimulatedVisualOdometry& vo,
                                 const std::vector<loop::LoopConstraint>& loops,
                                 const CorrectionOptions& options) {
  options.validate();
  if (vo.keyframes().empty()) throw std::invalid_argument("correction: the run has no keyframe");
  std::vector<loop::PoseGraphEdge> loop_edges;
  for (const loop::LoopConstraint& c : loops) {
    loop::PoseGraphEdge edge;
    edge.from = c.current_id;
    edge.to = c.loop_id;
    edge.S_from_to = c.S_current_loop;
    edge.information = options.loop_information * loop::Matrix7d::Identity();
    edge.kind = loop::EdgeKind::kLoop;
    loop_edges.push_back(edge);
  }
  loop::PoseGraphBuilderOptions builder;
  builder.min_shared_points = options.covisibility_min_shared_points;
  builder.information = options.odometry_information * loop::Matrix7d::Identity();
  return loop::buildPoseGraph(vo.map(), {}, loop_edges, {vo.keyframes().front().id}, builder);
}

std::vector<geometry::SE3> correctedFramePoses(
    const SimulatedVisualOdometry& vo,
    const std::map<map::KeyframeId, geometry::Sim3>& S_kf_world) {
  std::vector<geometry::SE3> T_world_cam;
  T_world_cam.reserve(vo.frameRecords().size());
  for (const FrameRecord& record : vo.frameRecords()) {
    const geometry::Sim3& S = S_kf_world.at(vo.keyframes()[record.keyframe].id);
    T_world_cam.push_back((geometry::Sim3(record.T_frame_kf) * S).toSE3().inverse());
  }
  return T_world_cam;
}

SimulationRun correctRun(const SimulatedVisualOdometry& vo, const SimulatedWorld& world,
                         const std::vector<loop::LoopConstraint>& loops,
                         const CorrectionOptions& options) {
  const common::Stopwatch timer;
  SimulationRun run;
  const map::Map& map = vo.map();
  run.frames = vo.frameRecords().size();
  run.keyframes = map.numKeyframes();
  run.points = map.numPoints();
  run.observations = map.numObservations();
  run.vo = vo.statistics();
  for (const loop::LoopConstraint& c : loops)
    run.loops.push_back(makeLoopRecord(vo, world, c));
  for (std::size_t i = 0; i < run.frames; ++i)
    run.T_world_cam_truth.push_back(world.T_cam_world.at(i).inverse());
  for (const geometry::SE3& T_cam_world : vo.framePosesThroughKeyframes())
    run.T_world_cam_before.push_back(T_cam_world.inverse());
  run.error_before =
      evaluation::firstPoseAlignedError(run.T_world_cam_before, run.T_world_cam_truth);

  const loop::PoseGraph graph = makeRunPoseGraph(vo, loops, options);
  run.graph.vertices = graph.vertices().size();
  run.graph.consecutive_edges = graph.numEdges(loop::EdgeKind::kConsecutive);
  run.graph.covisibility_edges = graph.numEdges(loop::EdgeKind::kCovisibility);
  run.graph.loop_edges = graph.numEdges(loop::EdgeKind::kLoop);
  run.se3 = solveVariant(vo, graph, loop::PoseGraphMode::kSE3, options, run.T_world_cam_truth);
  run.sim3 = solveVariant(vo, graph, loop::PoseGraphMode::kSim3, options, run.T_world_cam_truth);
  run.correction_time_s = timer.seconds();
  return run;
}

SimulationRun runExperiment(const std::string& name, const SimulatedWorld& world,
                            const SimulatedVoParams& vo_params, double noise_px, std::uint32_t seed,
                            std::mt19937& rng, const LoopMeasurer& measure_loops,
                            const CorrectionOptions& correction) {
  const common::Stopwatch timer;
  const double cpu_start = processCpuSeconds();
  SimulatedVisualOdometry vo(world.camera, vo_params);
  for (std::size_t i = 0; i < world.T_cam_world.size(); ++i)
    vo.processFrame(i, measureFrame(world, i, noise_px, rng), world.T_cam_world[i]);
  const double vo_time_s = timer.seconds();
  const std::vector<loop::LoopConstraint> loops = measure_loops(vo);
  const double loop_time_s = timer.seconds() - vo_time_s;
  SimulationRun run = correctRun(vo, world, loops, correction);
  run.experiment = name;
  run.seed = seed;
  run.noise_px = noise_px;
  run.vo_time_s = vo_time_s;
  run.loop_time_s = loop_time_s;
  run.total_time_s = timer.seconds();
  run.total_cpu_time_s = processCpuSeconds() - cpu_start;
  return run;
}

double processCpuSeconds() {
  return static_cast<double>(std::clock()) / CLOCKS_PER_SEC;
}

}  // namespace scale_drift_slam::sim
