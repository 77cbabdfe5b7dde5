// Output files of the Keble College experiment (sim/keble_experiment.h).

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <stdexcept>

#include "scale_drift_slam/io/plot.h"
#include "scale_drift_slam/io/trajectory_io.h"
#include "scale_drift_slam/sim/keble_experiment.h"

namespace scale_drift_slam::sim {
namespace {

nlohmann::json statsJson(const mapping::ReprojectionStats& stats) {
  return {{"observations", stats.observations},
          {"behind_camera", stats.behind},
          {"mean", stats.mean},
          {"rms", stats.rms},
          {"median", stats.median},
          {"p90", stats.p90}};
}

nlohmann::json variantJson(const KebleVariant& variant) {
  const loop::PoseGraphResult& graph = variant.graph;
  const mapping::StructureOnlyBAResult& structure = variant.structure;
  return {{"pose_graph",
           {{"iterations", graph.iterations},
            {"initial_chi2", graph.initial_chi2},
            {"final_chi2", graph.final_chi2},
            {"time_s", graph.time_s},
            {"converged", graph.converged},
            {"termination", graph.termination}}},
          {"structure_only_ba",
           {{"points", structure.points},
            {"points_skipped", structure.points_skipped},
            {"observations", structure.observations},
            {"max_iterations_used", structure.max_iterations_used},
            {"mean_iterations", structure.mean_iterations},
            {"initial_cost", structure.initial_cost},
            {"final_cost", structure.final_cost},
            {"time_s", structure.time_s}}},
          {"path_length", variant.path_length},
          {"loop_gap", variant.loop_gap},
          {"last_keyframe_scale", variant.last_keyframe_scale},
          {"reprojection_error_px",
           {{"after_correction", statsJson(variant.after_correction)},
            {"after_structure_only_ba", statsJson(structure.after)}}}};
}

void saveKeyframes(const std::string& path, const map::Map& map, const std::string& comment) {
  std::vector<io::StampedPose> poses;
  for (const auto& [id, keyframe] : map.keyframes()) {
    poses.push_back({static_cast<double>(id), keyframe.T_kf_world.inverse()});
  }
  io::saveTumTrajectory(path, poses, comment);
}

void savePoints(const std::string& path, const map::Map& map) {
  std::vector<map::PointId> ids;
  for (const auto& entry : map.points()) {
    ids.push_back(entry.first);
  }
  std::sort(ids.begin(), ids.end());
  std::ofstream file(path);
  file << "# point_id x y z (world frame)\n" << std::setprecision(10);
  for (const map::PointId id : ids) {
    const Eigen::Vector3d& p = map.point(id).p_world;
    file << id << ' ' << p.x() << ' ' << p.y() << ' ' << p.z() << '\n';
  }
  if (!file) {
    throw std::runtime_error("cannot write '" + path + "'");
  }
}

/// Camera centres in the top view: x to the right, z up (the view from above, y points down).
std::vector<Eigen::Vector2d> topView(const std::vector<Eigen::Vector3d>& centres) {
  std::vector<Eigen::Vector2d> xz;
  xz.reserve(centres.size());
  for (const Eigen::Vector3d& c : centres) {
    xz.emplace_back(c.x(), c.z());
  }
  return xz;
}

void savePlotFile(const std::string& path, const KebleExperimentResult& result) {
  char se3_label[96], sim3_label[96], before_label[96];
  std::snprintf(before_label, sizeof(before_label), "before loop closure (path %.1f)",
                result.path_length_before);
  std::snprintf(se3_label, sizeof(se3_label), "SE(3) pose graph (path %.1f, gap %.2f)",
                result.se3.path_length, result.se3.loop_gap);
  std::snprintf(sim3_label, sizeof(sim3_label), "Sim(3) pose graph (path %.1f, gap %.2f)",
                result.sim3.path_length, result.sim3.loop_gap);
  std::vector<io::PlotSeries> series = {
      {before_label, topView(result.centres_before), cv::Scalar(40, 40, 40), 2, false},
      {se3_label, topView(result.se3.centres), cv::Scalar(40, 160, 40), 2, false},
      {sim3_label, topView(result.sim3.centres), cv::Scalar(40, 40, 210), 2, false},
      {"loop keyframe " + std::to_string(result.loop_keyframe),
       topView({result.centres_before[result.loop_keyframe]}), cv::Scalar(200, 120, 30), 6, true}};
  io::PlotOptions options;
  options.title = "Keble College: keyframe camera centres, top view (x-z)";
  options.x_label = "x";
  options.y_label = "z";
  io::savePlot(path, series, options);
}

}  // namespace

nlohmann::json kebleSummary(const KebleExperimentResult& result, const io::KebleMap& keble) {
  return {{"experiment", "keble"},
          {"map",
           {{"keyframes", keble.map.numKeyframes()},
            {"points", keble.map.numPoints()},
            {"observations", keble.map.numObservations()},
            {"loop_keyframe", keble.loop_keyframe},
            {"current_pose", keble.current_id},
            {"loop_scale", keble.loop_scale},
            {"loop_edge_scale", 1.0 / keble.loop_scale}}},
          {"graph",
           {{"vertices", result.vertices},
            {"fixed", {result.loop_keyframe}},
            {"first_keyframe", result.loop_keyframe},
            {"last_keyframe", result.last_keyframe},
            {"consecutive_edges", result.consecutive_edges},
            {"covisibility_edges", result.covisibility_edges},
            {"loop_edges", result.loop_edges}}},
          {"before",
           {{"path_length", result.path_length_before},
            {"loop_gap", result.loop_gap_before},
            {"reprojection_error_px", statsJson(result.reprojection_before)}}},
          {"se3", variantJson(result.se3)},
          {"sim3", variantJson(result.sim3)}};
}

void writeKebleExperiment(const KebleExperimentResult& result, const io::KebleMap& keble,
                          const std::string& out_dir) {
  std::error_code error;
  std::filesystem::create_directories(out_dir, error);
  if (error || !std::filesystem::is_directory(out_dir)) {
    throw std::runtime_error("cannot create the output folder '" + out_dir + "'");
  }
  const std::string dir = out_dir + "/";
  saveKeyframes(dir + "before.tum", keble.map,
                "Keble College keyframes before loop closure (timestamp = keyframe index)");
  saveKeyframes(dir + "se3.tum", result.se3.map, "after SE(3) pose-graph correction");
  saveKeyframes(dir + "sim3.tum", result.sim3.map, "after Sim(3) pose-graph correction");
  savePoints(dir + "se3_points.txt", result.se3.map);
  savePoints(dir + "sim3_points.txt", result.sim3.map);
  savePlotFile(dir + "keble_top_view.png", result);
  std::ofstream summary(dir + "summary.json");
  summary << kebleSummary(result, keble).dump(2) << "\n";
  if (!summary) {
    throw std::runtime_error("cannot write '" + dir + "summary.json'");
  }
}

}  // namespace scale_drift_slam::sim
