#pragma once
// Scoring an estimated trajectory against ground truth: association by timestamp, Sim(3) (or
// SE(3)) alignment, absolute trajectory error (ATE), relative pose error (RPE) over fixed
// distances travelled, scale drift per segment, and the fraction of frames tracked. Used by the
// evaluate_trajectory tool; the report (JSON, text, plot) is in evaluation/evaluation_report.h.

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "scale_drift_slam/geometry/sim3.h"
#include "scale_drift_slam/io/trajectory_io.h"

namespace scale_drift_slam::evaluation {

enum class AlignmentMode { kSim3, kSE3 };
/// "sim3" or "se3"; throws std::invalid_argument otherwise.
AlignmentMode parseAlignmentMode(const std::string& name);
std::string alignmentModeName(AlignmentMode mode);

/// The parameters of the evaluation module.
struct EvaluationParams {
  AlignmentMode alignment = AlignmentMode::kSim3;
  double max_time_difference = 0.02;  ///< Seconds between associated stamps.
  std::vector<double> rpe_distances = {1.0, 2.0, 5.0, 10.0};  ///< Metres along the true path.
  int scale_segments = 10;  ///< Equal lengths of the true path for the scale drift.
  /// Use this alignment (S_truth_estimate) instead of estimating one, e.g. the one estimated on
  /// an earlier run in the same map (`alignment` then only names it in the report).
  std::optional<geometry::Sim3> given_alignment;
  void validate() const;  ///< Throws std::invalid_argument with the reason.
};

/// Pairs (truth index, estimate index) whose stamps differ by at most max_time_difference, each
/// pose used at most once (the nearest stamp wins), in time order. Inputs must be sorted by time.
std::vector<std::pair<size_t, size_t>> associateByTimestamp(
    const std::vector<io::StampedPose>& truth, const std::vector<io::StampedPose>& estimate,
    double max_time_difference);

struct ErrorStatistics {
  size_t count = 0;
  double rmse = 0, mean = 0, median = 0, min = 0, max = 0;
};
/// Statistics of a list of non-negative errors (all zero for an empty list).
ErrorStatistics errorStatistics(std::vector<double> errors);

/// RPE for one distance: for every frame i, the first frame j at least `distance` further along
/// the true path; error = (T_i^-1 T_j)_truth^-1 (T_i^-1 T_j)_estimate, with the estimate's
/// translations multiplied by the alignment scale.
struct RelativePoseError {
  double distance = 0;
  ErrorStatistics translation;   ///< Metres.
  ErrorStatistics rotation_deg;  ///< Degrees.
};

/// The scale of one segment: Umeyama Sim(3) scale between the segment's estimate (after the
/// whole estimate was aligned on the first segment) and the truth. 1 everywhere: no drift.
struct ScaleSegment {
  double start_distance = 0, end_distance = 0;  ///< Metres along the true path.
  double start_time = 0, end_time = 0;
  size_t frames = 0;
  double scale = 1;
};

struct TrajectoryEvaluation {
  AlignmentMode alignment = AlignmentMode::kSim3;
  size_t truth_frames = 0, estimate_frames = 0, matched_frames = 0;
  double tracked_fraction = 0;  ///< matched_frames / truth_frames.
  double truth_path_length = 0;
  geometry::Sim3 S_truth_estimate;  ///< The alignment (scale 1 for SE(3)).
  ErrorStatistics ate;              ///< Position errors after alignment, metres.
  std::vector<double> times;        ///< Stamps of the matched frames.
  std::vector<double> ate_errors;   ///< Per matched frame.
  std::vector<Eigen::Vector3d> truth_positions, aligned_positions;
  std::vector<RelativePoseError> rpe;  ///< Distances longer than the path are left out.
  std::vector<ScaleSegment> scale_segments;
  double scale_drift = 1;  ///< Scale of the last segment / scale of the first.
  /// Scale drift over the true path, in %: the least-squares slope b of log(scale) against the
  /// segments' middle distances, as 100 (exp(b L) - 1) for the path length L. 0 with fewer than
  /// two segments.
  double scale_drift_over_path = 0;
  /// The same slope per 100 m of the true path, 100 (exp(100 b) - 1), in %; NaN for a path
  /// shorter than kMinPathForDriftPer100m, where the extrapolation means nothing (a 20 % drift
  /// over 0.5 m would be ~10^18 % per 100 m).
  double scale_drift_per_100m = 0;
};

/// The shortest true path whose scale drift is extrapolated to 100 m, metres.
inline constexpr double kMinPathForDriftPer100m = 10.0;

/// Evaluates; throws std::invalid_argument for bad parameters and std::runtime_error when fewer
/// than 3 poses can be associated (naming the counts and the time tolerance).
TrajectoryEvaluation evaluateTrajectory(std::vector<io::StampedPose> truth,
                                        std::vector<io::StampedPose> estimate,
                                        const EvaluationParams& params = {});

}  // namespace scale_drift_slam::evaluation
