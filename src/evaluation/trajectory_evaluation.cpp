#include "scale_drift_slam/evaluation/trajectory_evaluation.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "scale_drift_slam/evaluation/alignment.h"

namespace scale_drift_slam::evaluation {
namespace {

/// The least-squares slope of log(scale) against the segments' middle distances, per metre of
/// the true path (TrajectoryEvaluation::scale_drift_over_path).
double logScaleSlopePerMetre(const std::vector<ScaleSegment>& segments) {
  if (segments.size() < 2) return 0.0;
  double mean_d = 0.0, mean_s = 0.0;
  for (const ScaleSegment& s : segments) {
    mean_d += 0.5 * (s.start_distance + s.end_distance);
    mean_s += std::log(s.scale);
  }
  mean_d /= segments.size();
  mean_s /= segments.size();
  double covariance = 0.0, spread = 0.0;
  for (const ScaleSegment& s : segments) {
    const double d = 0.5 * (s.start_distance + s.end_distance) - mean_d;
    covariance += d * (std::log(s.scale) - mean_s);
    spread += d * d;
  }
  if (!(spread > 0.0)) return 0.0;
  return covariance / spread;
}

geometry::Sim3 align(const std::vector<Eigen::Vector3d>& estimate,
                     const std::vector<Eigen::Vector3d>& truth, AlignmentMode mode) {
  if (mode == AlignmentMode::kSim3) return alignSim3(estimate, truth);
  const geometry::SE3 T = alignSE3(estimate, truth);
  return geometry::Sim3::fromScale(T.rotation(), T.translation(), 1.0);
}

/// Cumulative path length along the positions.
std::vector<double> pathLength(const std::vector<Eigen::Vector3d>& positions) {
  std::vector<double> length(positions.size(), 0.0);
  for (size_t i = 1; i < positions.size(); ++i) {
    length[i] = length[i - 1] + (positions[i] - positions[i - 1]).norm();
  }
  return length;
}

std::vector<RelativePoseError> relativeErrors(const std::vector<geometry::SE3>& truth,
                                              const std::vector<geometry::SE3>& estimate,
                                              const std::vector<double>& length, double scale,
                                              const std::vector<double>& distances) {
  std::vector<RelativePoseError> result;
  for (const double distance : distances) {
    if (length.empty() || length.back() < distance) continue;
    std::vector<double> translation, rotation;
    size_t j = 0;
    for (size_t i = 0; i < truth.size(); ++i) {
      j = std::max(j, i + 1);
      while (j < truth.size() && length[j] - length[i] < distance)
        ++j;
      if (j >= truth.size()) break;
      const geometry::SE3 delta_truth = truth[i].inverse() * truth[j];
      geometry::SE3 delta_estimate = estimate[i].inverse() * estimate[j];
      delta_estimate.translation() *= scale;
      const geometry::SE3 error = delta_truth.inverse() * delta_estimate;
      translation.push_back(error.translation().norm());
      rotation.push_back(Eigen::AngleAxisd(error.rotation()).angle() * 180.0 / M_PI);
    }
    if (translation.empty()) continue;
    RelativePoseError rpe;
    rpe.distance = distance;
    rpe.translation = errorStatistics(translation);
    rpe.rotation_deg = errorStatistics(rotation);
    result.push_back(rpe);
  }
  return result;
}

std::vector<ScaleSegment> scaleSegments(const std::vector<Eigen::Vector3d>& truth,
                                        const std::vector<Eigen::Vector3d>& estimate,
                                        const std::vector<double>& times,
                                        const std::vector<double>& length, int count,
                                        AlignmentMode mode) {
  // Frame ranges of equal true path length.
  std::vector<std::pair<size_t, size_t>> ranges;
  const double piece = length.back() / count;
  size_t begin = 0;
  for (int k = 1; k <= count && begin < truth.size(); ++k) {
    size_t end = begin;
    while (end < truth.size() && (k == count || length[end] < k * piece))
      ++end;
    if (end - begin >= 3) ranges.emplace_back(begin, end);
    begin = end;
  }
  std::vector<ScaleSegment> segments;
  if (ranges.empty()) return segments;
  auto slice = [](const std::vector<Eigen::Vector3d>& v, std::pair<size_t, size_t> r) {
    return std::vector<Eigen::Vector3d>(v.begin() + static_cast<long>(r.first),
                                        v.begin() + static_cast<long>(r.second));
  };
  // Align the whole estimate on the first part, then measure each part's own scale.
  const geometry::Sim3 S_first = align(slice(estimate, ranges[0]), slice(truth, ranges[0]), mode);
  std::vector<Eigen::Vector3d> aligned;
  for (const Eigen::Vector3d& p : estimate)
    aligned.push_back(S_first * p);
  for (const auto& range : ranges) {
    ScaleSegment segment;
    segment.start_distance = length[range.first];
    segment.end_distance = length[range.second - 1];
    segment.start_time = times[range.first];
    segment.end_time = times[range.second - 1];
    segment.frames = range.second - range.first;
    const std::vector<Eigen::Vector3d> part = slice(aligned, range);
    double spread = 0.0;
    for (const Eigen::Vector3d& p : part)
      spread = std::max(spread, (p - part.front()).norm());
    if (spread < 1e-9 || segment.end_distance - segment.start_distance < 1e-9) continue;
    segment.scale = alignSim3(part, slice(truth, range)).scale();
    segments.push_back(segment);
  }
  return segments;
}

}  // namespace

AlignmentMode parseAlignmentMode(const std::string& name) {
  if (name == "sim3") return AlignmentMode::kSim3;
  if (name == "se3") return AlignmentMode::kSE3;
  throw std::invalid_argument("alignment must be sim3 or se3, not '" + name + "'");
}

std::string alignmentModeName(AlignmentMode mode) {
  return mode == AlignmentMode::kSim3 ? "sim3" : "se3";
}

void EvaluationParams::validate() const {
  if (!(max_time_difference >= 0) || !std::isfinite(max_time_difference)) {
    throw std::invalid_argument("the time tolerance must be a finite number >= 0");
  }
  for (const double d : rpe_distances) {
    if (!(d > 0) || !std::isfinite(d)) throw std::invalid_argument("RPE distances must be > 0");
  }
  if (scale_segments < 1 || scale_segments > 1000) {
    throw std::invalid_argument("the number of scale segments must be in [1, 1000]");
  }
}

std::vector<std::pair<size_t, size_t>> associateByTimestamp(
    const std::vector<io::StampedPose>& truth, const std::vector<io::StampedPose>& estimate,
    double max_time_difference) {
  // Nearest truth stamp per estimate, then keep the closest estimate per truth pose.
  std::vector<std::pair<size_t, size_t>> pairs;
  std::vector<double> best(truth.size(), max_time_difference + 1.0);
  std::vector<long> owner(truth.size(), -1);
  for (size_t e = 0; e < estimate.size(); ++e) {
    const double t = estimate[e].timestamp;
    const auto it =
        std::lower_bound(truth.begin(), truth.end(), t,
                         [](const io::StampedPose& p, double s) { return p.timestamp < s; });
    size_t nearest = truth.size();
    double nearest_dt = max_time_difference + 1.0;
    for (auto candidate : {it, it == truth.begin() ? it : it - 1}) {
      if (candidate == truth.end()) continue;
      const double dt = std::abs(candidate->timestamp - t);
      if (dt < nearest_dt)
        nearest_dt = dt, nearest = static_cast<size_t>(candidate - truth.begin());
    }
    if (nearest == truth.size() || nearest_dt > max_time_difference) continue;
    if (nearest_dt < best[nearest])
      best[nearest] = nearest_dt, owner[nearest] = static_cast<long>(e);
  }
  for (size_t t = 0; t < truth.size(); ++t) {
    if (owner[t] >= 0) pairs.emplace_back(t, static_cast<size_t>(owner[t]));
  }
  return pairs;
}

ErrorStatistics errorStatistics(std::vector<double> errors) {
  ErrorStatistics s;
  s.count = errors.size();
  if (errors.empty()) return s;
  std::sort(errors.begin(), errors.end());
  double sum = 0, sum_sq = 0;
  for (const double e : errors)
    sum += e, sum_sq += e * e;
  s.mean = sum / errors.size();
  s.rmse = std::sqrt(sum_sq / errors.size());
  s.min = errors.front();
  s.max = errors.back();
  const size_t n = errors.size();
  s.median = n % 2 ? errors[n / 2] : 0.5 * (errors[n / 2 - 1] + errors[n / 2]);
  return s;
}

TrajectoryEvaluation evaluateTrajectory(std::vector<io::StampedPose> truth,
                                        std::vector<io::StampedPose> estimate,
                                        const EvaluationParams& params) {
  params.validate();
  auto by_time = [](const io::StampedPose& a, const io::StampedPose& b) {
    return a.timestamp < b.timestamp;
  };
  std::stable_sort(truth.begin(), truth.end(), by_time);
  std::stable_sort(estimate.begin(), estimate.end(), by_time);
  TrajectoryEvaluation result;
  result.alignment = params.alignment;
  result.truth_frames = truth.size();
  result.estimate_frames = estimate.size();
  const auto pairs = associateByTimestamp(truth, estimate, params.max_time_difference);
  if (pairs.size() < 3) {
    throw std::runtime_error(
        "only " + std::to_string(pairs.size()) + " of " + std::to_string(estimate.size()) +
        " estimated poses have a ground-truth "
        "pose within " +
        std::to_string(params.max_time_difference) + " s (" + std::to_string(truth.size()) +
        " ground-truth poses); at least 3 are needed");
  }
  result.matched_frames = pairs.size();
  result.tracked_fraction = truth.empty() ? 0.0 : static_cast<double>(pairs.size()) / truth.size();
  std::vector<Eigen::Vector3d> estimate_positions;
  std::vector<geometry::SE3> truth_poses, estimate_poses;
  for (const auto& [t, e] : pairs) {
    result.times.push_back(truth[t].timestamp);
    result.truth_positions.push_back(truth[t].T_world_cam.translation());
    estimate_positions.push_back(estimate[e].T_world_cam.translation());
    truth_poses.push_back(truth[t].T_world_cam);
    estimate_poses.push_back(estimate[e].T_world_cam);
  }
  result.S_truth_estimate =
      params.given_alignment ? *params.given_alignment
                             : align(estimate_positions, result.truth_positions, params.alignment);
  for (size_t i = 0; i < pairs.size(); ++i) {
    result.aligned_positions.push_back(result.S_truth_estimate * estimate_positions[i]);
    result.ate_errors.push_back((result.aligned_positions[i] - result.truth_positions[i]).norm());
  }
  result.ate = errorStatistics(result.ate_errors);
  const std::vector<double> length = pathLength(result.truth_positions);
  result.truth_path_length = length.back();
  result.rpe = relativeErrors(truth_poses, estimate_poses, length, result.S_truth_estimate.scale(),
                              params.rpe_distances);
  if (result.truth_path_length > 0) {
    result.scale_segments = scaleSegments(result.truth_positions, estimate_positions, result.times,
                                          length, params.scale_segments, params.alignment);
  }
  if (!result.scale_segments.empty()) {
    result.scale_drift = result.scale_segments.back().scale / result.scale_segments.front().scale;
  }
  const double slope = logScaleSlopePerMetre(result.scale_segments);
  result.scale_drift_over_path = 100.0 * (std::exp(slope * result.truth_path_length) - 1.0);
  result.scale_drift_per_100m = result.truth_path_length >= kMinPathForDriftPer100m
                                    ? 100.0 * (std::exp(100.0 * slope) - 1.0)
                                    : std::numeric_limits<double>::quiet_NaN();
  return result;
}

}  // namespace scale_drift_slam::evaluation
