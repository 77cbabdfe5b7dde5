#pragma once
// Reporting a trajectory evaluation (evaluation/trajectory_evaluation.h): JSON for machines, a
// few lines for people, and a PNG with the top view and the error over time.

#include <string>

#include <nlohmann/json.hpp>

#include "scale_drift_slam/evaluation/trajectory_evaluation.h"

namespace scale_drift_slam::evaluation {

/// Everything except the per-frame lists: counts, alignment, ATE, RPE, scale segments.
nlohmann::json toJson(const TrajectoryEvaluation& evaluation);
/// The alignment (S_truth_estimate) of a toJson() report ("alignment_transform"). Throws
/// std::invalid_argument when it is missing or malformed.
geometry::Sim3 alignmentFromJson(const nlohmann::json& report);
/// A human summary, one figure per line.
std::string summaryText(const TrajectoryEvaluation& evaluation);
/// Two panels side by side: the top view (x, y) of the truth and the aligned estimate, and the
/// position error over time. Throws std::runtime_error when the file cannot be written.
void saveEvaluationPlot(const std::string& path, const TrajectoryEvaluation& evaluation);

}  // namespace scale_drift_slam::evaluation
