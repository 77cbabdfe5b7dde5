#include "scale_drift_slam/sim/simulation_output.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <stdexcept>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "scale_drift_slam/io/plot.h"
#include "scale_drift_slam/io/trajectory_io.h"

namespace scale_drift_slam::sim {
namespace {

const char* const kTrajectoryNote =
    "every frame (T_world_cam, timestamp = frame index); a frame between keyframes follows the "
    "correction of its reference keyframe (the newest keyframe when it was tracked)";

void makeFolder(const std::string& dir) {
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error || !std::filesystem::is_directory(dir)) {
    throw std::runtime_error("cannot create the output folder '" + dir + "'");
  }
}

void writeJson(const std::string& path, const nlohmann::json& json) {
  std::ofstream file(path);
  file << json.dump(2) << "\n";
  if (!file) throw std::runtime_error("cannot write '" + path + "'");
}

nlohmann::json errorJson(const evaluation::FirstPoseAlignedError& error) {
  return {{"position_rmse", error.rmse}, {"alignment_scale", error.scale}};
}

nlohmann::json graphJson(const loop::PoseGraphResult& graph) {
  return {{"iterations", graph.iterations}, {"initial_chi2", graph.initial_chi2},
          {"final_chi2", graph.final_chi2}, {"time_s", graph.time_s},
          {"converged", graph.converged},   {"termination", graph.termination}};
}

nlohmann::json loopJson(const LoopRecord& loop) {
  return {{"current_keyframe", loop.current_keyframe},
          {"loop_keyframe", loop.loop_keyframe},
          {"current_frame", loop.current_frame},
          {"loop_frame", loop.loop_frame},
          {"measured_scale", loop.measured_scale},
          {"measured_scale_change_percent", 100.0 * (loop.measured_scale - 1.0)},
          {"true_scale", loop.true_scale},
          {"inliers", loop.inliers},
          {"scale_pairs", loop.scale_pairs},
          {"rmse_px", loop.rmse_px}};
}

double median(std::vector<double> values) {
  if (values.empty()) return std::nan("");
  auto middle = values.begin() + values.size() / 2;
  std::nth_element(values.begin(), middle, values.end());
  if (values.size() % 2 == 1) return *middle;
  return 0.5 * (*middle + *std::max_element(values.begin(), middle));
}

double mean(const std::vector<double>& values) {
  double sum = 0.0;
  for (double v : values)
    sum += v;
  return values.empty() ? std::nan("") : sum / static_cast<double>(values.size());
}

/// The largest |log s| of a run's loops as a percentage (the run's scale drift at its loops).
double maxScaleChangePercent(const SimulationRun& run) {
  double worst = 0.0;
  for (const LoopRecord& loop : run.loops)
    worst = std::max(worst, std::abs(std::log(loop.measured_scale)));
  return 100.0 * (std::exp(worst) - 1.0);
}

nlohmann::json statJson(const std::vector<SimulationRun>& runs,
                        const std::function<double(const SimulationRun&)>& figure) {
  std::vector<double> values;
  for (const SimulationRun& run : runs)
    values.push_back(figure(run));
  return {{"mean", mean(values)}, {"median", median(values)}};
}

void saveTrajectory(const std::string& path, const std::vector<geometry::SE3>& T_world_cam,
                    const std::string& comment) {
  std::vector<io::StampedPose> poses;
  for (std::size_t i = 0; i < T_world_cam.size(); ++i)
    poses.push_back({static_cast<double>(i), T_world_cam[i]});
  io::saveTumTrajectory(path, poses, comment);
}

std::vector<Eigen::Vector2d> topView(const std::vector<geometry::SE3>& T_world_cam) {
  std::vector<Eigen::Vector2d> xy;
  for (const geometry::SE3& T : T_world_cam)
    xy.emplace_back(T.translation().x(), T.translation().y());
  return xy;
}

void saveTopView(const std::string& path, const SimulationRun& run) {
  char before[96], se3[96], sim3[96], title[128];
  std::snprintf(before, sizeof(before), "before loop closure (RMSE %.3f)", run.error_before.rmse);
  std::snprintf(se3, sizeof(se3), "SE(3) pose graph (RMSE %.3f)", run.se3.error.rmse);
  std::snprintf(sim3, sizeof(sim3), "Sim(3) pose graph (RMSE %.3f)", run.sim3.error.rmse);
  std::snprintf(title, sizeof(title), "%s, %.2f px noise, seed %u: camera centres, top view (x-y)",
                run.experiment.c_str(), run.noise_px, run.seed);
  const std::vector<io::PlotSeries> series = {
      {"ground truth", topView(run.T_world_cam_truth), cv::Scalar(170, 170, 170), 4, false},
      {before, topView(run.T_world_cam_before), cv::Scalar(40, 40, 40), 1, false},
      {se3, topView(run.se3.T_world_cam), cv::Scalar(40, 160, 40), 2, false},
      {sim3, topView(run.sim3.T_world_cam), cv::Scalar(40, 40, 210), 2, false}};
  io::PlotOptions options;
  options.title = title;
  options.width = 800;
  options.height = 700;
  io::savePlot(path, series, options);
}

void writeRunFiles(const SimulationRun& run, const std::string& dir) {
  const std::string name = run.experiment + " simulation, seed " + std::to_string(run.seed);
  saveTrajectory(dir + "/truth.tum", run.T_world_cam_truth, name + ": ground truth");
  saveTrajectory(dir + "/before.tum", run.T_world_cam_before,
                 name + ": visual odometry before loop closure");
  saveTrajectory(dir + "/se3.tum", run.se3.T_world_cam, name + ": after SE(3) correction");
  saveTrajectory(dir + "/sim3.tum", run.sim3.T_world_cam, name + ": after Sim(3) correction");
  saveTopView(dir + "/" + run.experiment + "_top_view.png", run);
}

std::vector<Eigen::Vector2d> curve(const std::vector<NoiseLevelRuns>& levels,
                                   const std::function<double(const SimulationRun&)>& figure) {
  std::vector<Eigen::Vector2d> points;
  for (const NoiseLevelRuns& level : levels) {
    std::vector<double> values;
    for (const SimulationRun& run : level.runs)
      values.push_back(figure(run));
    points.emplace_back(level.noise_px, mean(values));
  }
  return points;
}

}  // namespace

nlohmann::json runJson(const SimulationRun& run) {
  nlohmann::json loops = nlohmann::json::array();
  for (const LoopRecord& loop : run.loops)
    loops.push_back(loopJson(loop));
  const SimulatedVoStatistics& vo = run.vo;
  return {{"experiment", run.experiment},
          {"seed", run.seed},
          {"noise_px", run.noise_px},
          {"trajectory", kTrajectoryNote},
          {"map",
           {{"frames", run.frames},
            {"keyframes", run.keyframes},
            {"points", run.points},
            {"observations", run.observations}}},
          {"visual_odometry",
           {{"lost_frames", vo.lost_frames},
            {"filters_started", vo.filters_started},
            {"promoted", vo.promoted},
            {"promotions_rejected", vo.promotions_rejected},
            {"window_ba_runs", vo.window_ba_runs},
            {"window_ba_ms_mean", vo.window_ba_runs ? vo.window_ba_ms / vo.window_ba_runs : 0.0},
            {"motion_ba_ms_mean", vo.frames ? vo.motion_ba_ms / vo.frames : 0.0}}},
          {"loops", loops},
          {"graph",
           {{"vertices", run.graph.vertices},
            {"fixed", "the first keyframe"},
            {"consecutive_edges", run.graph.consecutive_edges},
            {"covisibility_edges", run.graph.covisibility_edges},
            {"loop_edges", run.graph.loop_edges}}},
          {"error",
           {{"measure",
             "first pose aligned, global scale by least squares over all frames, RMSE of camera "
             "positions (paper)"},
            {"before", errorJson(run.error_before)},
            {"se3", errorJson(run.se3.error)},
            {"sim3", errorJson(run.sim3.error)},
            {"sim3_over_se3", run.sim3.error.rmse / run.se3.error.rmse}}},
          {"pose_graph", {{"se3", graphJson(run.se3.graph)}, {"sim3", graphJson(run.sim3.graph)}}},
          {"time_s",
           {{"visual_odometry", run.vo_time_s},
            {"loop_measurement", run.loop_time_s},
            {"correction", run.correction_time_s},
            {"total_wall", run.total_time_s},
            {"total_cpu", run.total_cpu_time_s}}}};
}

nlohmann::json aggregateJson(const std::vector<SimulationRun>& runs) {
  return {{"runs", runs.size()},
          {"before_rmse", statJson(runs, [](const auto& r) { return r.error_before.rmse; })},
          {"se3_rmse", statJson(runs, [](const auto& r) { return r.se3.error.rmse; })},
          {"sim3_rmse", statJson(runs, [](const auto& r) { return r.sim3.error.rmse; })},
          {"sim3_over_se3",
           statJson(runs, [](const auto& r) { return r.sim3.error.rmse / r.se3.error.rmse; })},
          {"max_loop_scale_change_percent", statJson(runs, maxScaleChangePercent)},
          {"total_cpu_time_s", statJson(runs, [](const auto& r) { return r.total_cpu_time_s; })},
          {"total_wall_time_s", statJson(runs, [](const auto& r) { return r.total_time_s; })}};
}

void writeRun(const SimulationRun& run, const nlohmann::json& params, const std::string& dir) {
  makeFolder(dir);
  writeRunFiles(run, dir);
  nlohmann::json summary = runJson(run);
  summary["parameters"] = params;
  writeJson(dir + "/summary.json", summary);
}

void writeRuns(const std::vector<SimulationRun>& runs, const nlohmann::json& params,
               const std::string& dir) {
  if (runs.empty()) throw std::invalid_argument("writeRuns: no run");
  if (runs.size() == 1) {
    writeRun(runs.front(), params, dir);
    return;
  }
  makeFolder(dir);
  nlohmann::json each = nlohmann::json::array();
  for (std::size_t k = 0; k < runs.size(); ++k) {
    char name[32];
    std::snprintf(name, sizeof(name), "/run_%02zu", k);
    writeRun(runs[k], params, dir + name);
    each.push_back(runJson(runs[k]));
  }
  writeRunFiles(runs.front(), dir);
  writeJson(dir + "/summary.json", {{"experiment", runs.front().experiment},
                                    {"parameters", params},
                                    {"trajectories_in_this_folder", "run 0 (run_00)"},
                                    {"aggregate", aggregateJson(runs)},
                                    {"runs", each}});
}

void writeNoiseSweep(const std::vector<NoiseLevelRuns>& levels, const nlohmann::json& params,
                     const std::string& dir) {
  if (levels.empty()) throw std::invalid_argument("writeNoiseSweep: no noise level");
  makeFolder(dir);
  nlohmann::json json_levels = nlohmann::json::array();
  for (const NoiseLevelRuns& level : levels) {
    nlohmann::json each = nlohmann::json::array();
    for (const SimulationRun& run : level.runs) {
      nlohmann::json figures = runJson(run);
      each.push_back({{"seed", run.seed},
                      {"error", figures["error"]},
                      {"loops", figures["loops"]},
                      {"time_s", figures["time_s"]}});
    }
    json_levels.push_back(
        {{"noise_px", level.noise_px}, {"aggregate", aggregateJson(level.runs)}, {"runs", each}});
  }
  writeJson(dir + "/summary.json", {{"experiment", levels.front().runs.front().experiment},
                                    {"noise_sweep", true},
                                    {"parameters", params},
                                    {"levels", json_levels}});

  io::PlotOptions rmse_options;
  rmse_options.title = "position RMSE after loop closure (mean over runs)";
  rmse_options.x_label = "image noise (px)";
  rmse_options.y_label = "RMSE";
  rmse_options.equal_axes = false;
  rmse_options.width = 800;
  rmse_options.height = 450;
  const cv::Mat rmse =
      io::renderPlot({{"SE(3)", curve(levels, [](const auto& r) { return r.se3.error.rmse; }),
                       cv::Scalar(40, 160, 40), 2, false},
                      {"Sim(3)", curve(levels, [](const auto& r) { return r.sim3.error.rmse; }),
                       cv::Scalar(40, 40, 210), 2, false}},
                     rmse_options);
  io::PlotOptions scale_options = rmse_options;
  scale_options.title = "scale drift at the loop, |scale change| % (mean over runs)";
  scale_options.y_label = "%";
  const cv::Mat scale = io::renderPlot(
      {{"scale drift", curve(levels, maxScaleChangePercent), cv::Scalar(200, 120, 30), 2, false}},
      scale_options);
  cv::Mat both;
  cv::vconcat(rmse, scale, both);
  const std::string path = dir + "/noise_sweep.png";
  if (!cv::imwrite(path, both)) throw std::runtime_error("cannot write plot '" + path + "'");
}

}  // namespace scale_drift_slam::sim
