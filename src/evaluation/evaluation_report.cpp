#include "scale_drift_slam/evaluation/evaluation_report.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>

#include "scale_drift_slam/io/plot.h"

namespace scale_drift_slam::evaluation {
namespace {

nlohmann::json statisticsJson(const ErrorStatistics& s) {
  return {{"count", s.count},   {"rmse", s.rmse}, {"mean", s.mean},
          {"median", s.median}, {"min", s.min},   {"max", s.max}};
}

std::string format(const char* pattern, double a, double b = 0, double c = 0, double d = 0) {
  char buffer[256];
  std::snprintf(buffer, sizeof(buffer), pattern, a, b, c, d);
  return buffer;
}

}  // namespace

geometry::Sim3 alignmentFromJson(const nlohmann::json& report) {
  try {
    const nlohmann::json& a = report.at("alignment_transform");
    const double scale = a.at("scale").get<double>();
    const auto t = a.at("translation").get<std::vector<double>>();
    const auto q = a.at("quaternion_xyzw").get<std::vector<double>>();
    if (t.size() != 3 || q.size() != 4 || !(scale > 0.0)) throw std::invalid_argument("sizes");
    return geometry::Sim3::fromScale(Eigen::Quaterniond(q[3], q[0], q[1], q[2]).normalized(),
                                     Eigen::Vector3d(t[0], t[1], t[2]), scale);
  } catch (const std::exception& e) {
    throw std::invalid_argument(
        std::string("no valid alignment_transform (scale > 0, translation[3], "
                    "quaternion_xyzw[4]) in the report: ") +
        e.what());
  }
}

nlohmann::json toJson(const TrajectoryEvaluation& e) {
  nlohmann::json json;
  json["alignment"] = alignmentModeName(e.alignment);
  json["frames"] = {{"ground_truth", e.truth_frames},
                    {"estimate", e.estimate_frames},
                    {"tracked", e.matched_frames},
                    {"tracked_fraction", e.tracked_fraction}};
  json["ground_truth_path_length"] = e.truth_path_length;
  const Eigen::Quaterniond& q = e.S_truth_estimate.rotation();
  const Eigen::Vector3d& t = e.S_truth_estimate.translation();
  json["alignment_transform"] = {{"scale", e.S_truth_estimate.scale()},
                                 {"translation", {t.x(), t.y(), t.z()}},
                                 {"quaternion_xyzw", {q.x(), q.y(), q.z(), q.w()}}};
  json["ate"] = statisticsJson(e.ate);
  json["rpe"] = nlohmann::json::array();
  for (const RelativePoseError& r : e.rpe) {
    json["rpe"].push_back({{"distance", r.distance},
                           {"translation", statisticsJson(r.translation)},
                           {"translation_percent", 100.0 * r.translation.rmse / r.distance},
                           {"rotation_deg", statisticsJson(r.rotation_deg)}});
  }
  json["scale_segments"] = nlohmann::json::array();
  for (const ScaleSegment& s : e.scale_segments) {
    json["scale_segments"].push_back({{"start_distance", s.start_distance},
                                      {"end_distance", s.end_distance},
                                      {"start_time", s.start_time},
                                      {"end_time", s.end_time},
                                      {"frames", s.frames},
                                      {"scale", s.scale}});
  }
  json["scale_drift"] = e.scale_drift;
  json["scale_drift_over_path_percent"] = e.scale_drift_over_path;
  json["scale_drift_per_100m_percent"] =
      std::isfinite(e.scale_drift_per_100m) ? nlohmann::json(e.scale_drift_per_100m) : nullptr;
  return json;
}

std::string summaryText(const TrajectoryEvaluation& e) {
  std::string text;
  text += "frames tracked      " + std::to_string(e.matched_frames) + " of " +
          std::to_string(e.truth_frames) +
          format(" (%.1f %%), estimate has ", 100 * e.tracked_fraction) +
          std::to_string(e.estimate_frames) + "\n";
  text += format("path length         %.3f m (ground truth)\n", e.truth_path_length);
  text += "alignment           " + alignmentModeName(e.alignment) +
          format(", scale %.6g\n", e.S_truth_estimate.scale());
  text += format("ATE  rmse %.4f  mean %.4f  median %.4f  max %.4f m\n", e.ate.rmse, e.ate.mean,
                 e.ate.median, e.ate.max);
  for (const RelativePoseError& r : e.rpe) {
    text += format("RPE  %5.1f m: rmse %.4f m (%.2f %%), ", r.distance, r.translation.rmse,
                   100.0 * r.translation.rmse / r.distance) +
            format("mean rotation %.3f deg over %.0f pairs\n", r.rotation_deg.mean,
                   static_cast<double>(r.translation.count));
  }
  if (!e.scale_segments.empty()) {
    text += "scale per segment  ";
    for (const ScaleSegment& s : e.scale_segments)
      text += format(" %.4f", s.scale);
    text += format("\nscale drift         %.4f (last segment / first), %+.2f %% over the path",
                   e.scale_drift, e.scale_drift_over_path);
    text += std::isfinite(e.scale_drift_per_100m)
                ? format(", %+.2f %% per 100 m\n", e.scale_drift_per_100m)
                : format(" (not extrapolated to 100 m from a path under %.0f m)\n",
                         kMinPathForDriftPer100m);
  }
  return text;
}

void saveEvaluationPlot(const std::string& path, const TrajectoryEvaluation& e) {
  io::PlotSeries truth{"ground truth", {}, io::plotColor(3), 2, false};
  io::PlotSeries estimate{
      "estimate (" + alignmentModeName(e.alignment) + " aligned)", {}, io::plotColor(0), 2, false};
  for (size_t i = 0; i < e.truth_positions.size(); ++i) {
    truth.points.emplace_back(e.truth_positions[i].x(), e.truth_positions[i].y());
    estimate.points.emplace_back(e.aligned_positions[i].x(), e.aligned_positions[i].y());
  }
  io::PlotOptions top;
  top.title = "top view";
  top.x_label = "x [m]";
  top.y_label = "y [m]";
  top.width = 800;
  top.height = 700;
  io::PlotSeries error{"position error", {}, io::plotColor(1), 2, false};
  const double t0 = e.times.empty() ? 0.0 : e.times.front();
  for (size_t i = 0; i < e.times.size(); ++i)
    error.points.emplace_back(e.times[i] - t0, e.ate_errors[i]);
  io::PlotOptions over_time;
  over_time.title = format("ATE rmse %.4f m", e.ate.rmse);
  over_time.x_label = "time [s]";
  over_time.y_label = "error [m]";
  over_time.width = 800;
  over_time.height = 700;
  over_time.equal_axes = false;
  cv::Mat image;
  cv::hconcat(io::renderPlot({truth, estimate}, top), io::renderPlot({error}, over_time), image);
  bool written = false;
  try {
    written = cv::imwrite(path, image);
  } catch (const cv::Exception&) {
    written = false;
  }
  if (!written) throw std::runtime_error("cannot write plot '" + path + "'");
}

}  // namespace scale_drift_slam::evaluation
