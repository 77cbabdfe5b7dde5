#include "scale_drift_slam/mapping/window_bundle_adjustment.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <memory>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include <ceres/ceres.h>

#include "scale_drift_slam/common/stopwatch.h"

#include "scale_drift_slam/features/reprojection_cost.h"

namespace scale_drift_slam::mapping {

void WindowBundleAdjustmentParams::validate() const {
  auto fail = [](const std::string& what) {
    throw std::invalid_argument("window bundle adjustment: " + what);
  };
  if (num_fixed_keyframes < 2) fail("num_fixed_keyframes must be >= 2 (7-DoF gauge)");
  if (window_size <= num_fixed_keyframes) fail("window_size must exceed num_fixed_keyframes");
  if (!(huber_width_px > 0.0)) fail("huber_width_px must be > 0");
  if (!(inlier_threshold_px > 0.0)) fail("inlier_threshold_px must be > 0");
  if (max_iterations < 1) fail("max_iterations must be >= 1");
  if (!(function_tolerance > 0.0)) fail("function_tolerance must be > 0");
  if (num_threads < 1) fail("num_threads must be >= 1");
}

void WindowBundleInput::validate() const {
  auto fail = [](const std::string& what) {
    throw std::invalid_argument("window bundle adjustment input: " + what);
  };
  if (!(focal_length_px > 0.0) || !std::isfinite(focal_length_px)) {
    fail("focal_length_px must be positive and finite");
  }
  for (const BundleKeyframe& kf : keyframes) {
    if (!kf.T_kf_world.translation().allFinite() || !kf.T_kf_world.rotation().coeffs().allFinite())
      fail("keyframe " + std::to_string(kf.id) + " has a non-finite pose");
  }
  for (const BundlePoint& p : points) {
    if (!p.p_world.allFinite()) fail("point " + std::to_string(p.id) + " is not finite");
  }
  for (const BundleObservation& o : observations) {
    if (o.keyframe_index >= keyframes.size() || o.point_index >= points.size())
      fail("an observation refers to a keyframe or point index out of range");
    if (!o.xy.allFinite()) fail("an observation is not finite");
  }
}

WindowBundleInput makeWindowInput(const map::Map& map, const WindowBundleAdjustmentParams& params,
                                  double focal_length_px) {
  params.validate();
  if (map.numKeyframes() < static_cast<std::size_t>(params.num_fixed_keyframes) + 1) {
    throw std::invalid_argument("window bundle adjustment needs at least " +
                                std::to_string(params.num_fixed_keyframes + 1) + " keyframes");
  }
  WindowBundleInput input;
  input.focal_length_px = focal_length_px;
  const std::size_t n = std::min<std::size_t>(params.window_size, map.numKeyframes());
  auto first = map.keyframes().end();
  std::advance(first, -static_cast<long>(n));
  // Per point: its observations in the window and those in free window keyframes.
  struct Count {
    int window = 0;
    int free = 0;
  };
  std::unordered_map<map::PointId, Count> counts;
  std::size_t k = 0;
  for (auto it = first; it != map.keyframes().end(); ++it, ++k) {
    const bool fixed = k < static_cast<std::size_t>(params.num_fixed_keyframes);
    for (const map::Observation& obs : it->second.observations) {
      Count& count = counts[obs.point_id];
      ++count.window;
      count.free += fixed ? 0 : 1;
    }
  }
  // A point that no free keyframe sees constrains no free pose: it is left out, so that it keeps
  // the estimate its older observations gave it instead of being re-triangulated from the two
  // fixed keyframes alone (a short baseline; it would lose that information).
  std::unordered_map<map::PointId, std::size_t> point_index;
  k = 0;
  for (auto it = first; it != map.keyframes().end(); ++it, ++k) {
    const map::Keyframe& kf = it->second;
    input.keyframes.push_back(
        {kf.id, kf.T_kf_world, k < static_cast<std::size_t>(params.num_fixed_keyframes)});
    for (const map::Observation& obs : kf.observations) {
      const Count& count = counts.at(obs.point_id);
      if (count.free == 0) continue;
      auto [entry, inserted] = point_index.try_emplace(obs.point_id, input.points.size());
      if (inserted) {
        // Seen by a single window keyframe: fixed (it still constrains that keyframe's pose).
        input.points.push_back({obs.point_id, map.point(obs.point_id).p_world, count.window < 2});
      }
      input.observations.push_back({k, entry->second, obs.xyd()});
    }
  }
  return input;
}

namespace {

/// Pixel error of every observation at the given estimate; NaN when not in front.
std::vector<double> pixelErrors(const WindowBundleInput& input,
                                const std::vector<std::array<double, 7>>& poses,
                                const std::vector<Eigen::Vector3d>& points) {
  std::vector<double> errors(input.observations.size());
  for (std::size_t i = 0; i < input.observations.size(); ++i) {
    const BundleObservation& o = input.observations[i];
    Eigen::Vector2d r;
    errors[i] = features::reprojectionResidual(
                    geometry::SE3::fromData(poses[o.keyframe_index].data()), points[o.point_index],
                    o.xy, input.focal_length_px, &r, nullptr, nullptr)
                    ? r.norm()
                    : std::nan("");
  }
  return errors;
}

double robustCost(const std::vector<double>& errors, double width) {
  double cost = 0.0;
  for (double e : errors) {
    if (std::isfinite(e)) cost += features::pseudoHuber(e * e, width);
  }
  return cost;
}

/// The estimate Ceres works on: poses as 7 numbers (features::SE3LeftManifold), points in world.
struct WindowEstimate {
  std::vector<std::array<double, 7>> poses;
  std::vector<Eigen::Vector3d> points;
};

WindowEstimate initialEstimate(const WindowBundleInput& input) {
  WindowEstimate estimate;
  estimate.poses.resize(input.keyframes.size());
  for (std::size_t k = 0; k < input.keyframes.size(); ++k)
    input.keyframes[k].T_kf_world.toData(estimate.poses[k].data());
  estimate.points.reserve(input.points.size());
  for (const BundlePoint& p : input.points)
    estimate.points.push_back(p.p_world);
  return estimate;
}

ceres::Problem::Options borrowingProblemOptions() {
  ceres::Problem::Options options;
  options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  return options;
}

/// The Ceres problem over an estimate. The problem borrows costs, kernel and manifold: they are
/// members, so they live as long as it does.
class WindowProblem {
 public:
  /// Observations not in front of their camera at the start (NaN initial error) are left out.
  WindowProblem(const WindowBundleInput& input, const std::vector<double>& initial_errors,
                double huber_width_px, WindowEstimate* estimate)
      : problem_(borrowingProblemOptions()), pseudo_huber_(huber_width_px) {
    addResiduals(input, initial_errors, estimate);
    setBlocks(input, estimate);
  }

  /// Solves, or reports "nothing to optimise" when every used block is fixed.
  void solve(const WindowBundleAdjustmentParams& params, features::BundleStatistics* stats) {
    if (!any_free_ || costs_.empty()) {
      stats->converged = true;
      stats->message = "nothing to optimise";
      return;
    }
    ceres::Solver::Options options;
    options.linear_solver_type = ceres::SPARSE_SCHUR;
    options.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
    options.linear_solver_ordering = ordering_;
    options.max_num_iterations = params.max_iterations;
    options.function_tolerance = params.function_tolerance;
    options.num_threads = params.num_threads;
    options.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    ceres::Solve(options, &problem_, &summary);
    stats->iterations = static_cast<int>(summary.iterations.size()) - 1;
    stats->converged = summary.termination_type == ceres::CONVERGENCE;
    stats->message = summary.message;
  }

 private:
  void addResiduals(const WindowBundleInput& input, const std::vector<double>& initial_errors,
                    WindowEstimate* estimate) {
    pose_used_.assign(estimate->poses.size(), false);
    point_used_.assign(estimate->points.size(), false);
    for (std::size_t i = 0; i < input.observations.size(); ++i) {
      if (!std::isfinite(initial_errors[i])) continue;
      const BundleObservation& o = input.observations[i];
      costs_.emplace_back(o.xy, input.focal_length_px);
      problem_.AddResidualBlock(&costs_.back(), &pseudo_huber_,
                                estimate->poses[o.keyframe_index].data(),
                                estimate->points[o.point_index].data());
      pose_used_[o.keyframe_index] = point_used_[o.point_index] = true;
    }
  }

  /// Manifolds, fixed blocks and the Schur ordering of the blocks the residuals use.
  void setBlocks(const WindowBundleInput& input, WindowEstimate* estimate) {
    for (std::size_t k = 0; k < estimate->poses.size(); ++k) {
      if (!pose_used_[k]) continue;
      double* pose = estimate->poses[k].data();
      problem_.SetManifold(pose, &se3_manifold_);
      if (input.keyframes[k].fixed) problem_.SetParameterBlockConstant(pose);
      any_free_ |= !input.keyframes[k].fixed;
      ordering_->AddElementToGroup(pose, 1);
    }
    for (std::size_t j = 0; j < estimate->points.size(); ++j) {
      if (!point_used_[j]) continue;
      double* point = estimate->points[j].data();
      if (input.points[j].fixed) problem_.SetParameterBlockConstant(point);
      any_free_ |= !input.points[j].fixed;
      ordering_->AddElementToGroup(point, 0);  // eliminated first (Schur complement)
    }
  }

  ceres::Problem problem_;
  ceres::SoftLOneLoss pseudo_huber_;  // see features::pseudoHuber
  features::SE3LeftManifold se3_manifold_;
  std::deque<features::ReprojectionCost> costs_;  // stable addresses, no copies
  std::vector<bool> pose_used_, point_used_;
  std::shared_ptr<ceres::ParameterBlockOrdering> ordering_ =
      std::make_shared<ceres::ParameterBlockOrdering>();
  bool any_free_ = false;
};

/// Costs, inliers (below the threshold before and after) and their RMSE before and after.
void summarise(const WindowBundleInput& input, const WindowBundleAdjustmentParams& params,
               const std::vector<double>& initial_errors, const std::vector<double>& final_errors,
               WindowBundleResult* result) {
  features::BundleStatistics& stats = result->statistics;
  stats.initial_cost = robustCost(initial_errors, params.huber_width_px);
  stats.final_cost = robustCost(final_errors, params.huber_width_px);
  stats.num_observations = input.observations.size();
  result->inlier.resize(input.observations.size());
  double initial_sq = 0.0, final_sq = 0.0;
  for (std::size_t i = 0; i < final_errors.size(); ++i) {
    result->inlier[i] = std::isfinite(final_errors[i]) && std::isfinite(initial_errors[i]) &&
                        final_errors[i] < params.inlier_threshold_px;
    if (!result->inlier[i]) continue;
    ++stats.num_inliers;
    initial_sq += initial_errors[i] * initial_errors[i];
    final_sq += final_errors[i] * final_errors[i];
  }
  if (stats.num_inliers > 0) {
    stats.initial_rmse_px = std::sqrt(initial_sq / stats.num_inliers);
    stats.final_rmse_px = std::sqrt(final_sq / stats.num_inliers);
  }
}

/// The input's keyframes and points with the free ones moved to the estimate.
void writeEstimate(const WindowBundleInput& input, const WindowEstimate& estimate,
                   WindowBundleResult* result) {
  result->keyframes = input.keyframes;
  for (std::size_t k = 0; k < estimate.poses.size(); ++k) {
    if (!input.keyframes[k].fixed)
      result->keyframes[k].T_kf_world = geometry::SE3::fromData(estimate.poses[k].data());
  }
  result->points = input.points;
  for (std::size_t j = 0; j < estimate.points.size(); ++j)
    result->points[j].p_world = estimate.points[j];
}

}  // namespace

WindowBundleResult solveWindowBundleAdjustment(const WindowBundleInput& input,
                                               const WindowBundleAdjustmentParams& params) {
  const common::Stopwatch timer;
  params.validate();
  input.validate();
  WindowEstimate estimate = initialEstimate(input);
  const std::vector<double> initial_errors = pixelErrors(input, estimate.poses, estimate.points);

  WindowBundleResult result;
  WindowProblem problem(input, initial_errors, params.huber_width_px, &estimate);
  problem.solve(params, &result.statistics);

  const std::vector<double> final_errors = pixelErrors(input, estimate.poses, estimate.points);
  summarise(input, params, initial_errors, final_errors, &result);
  writeEstimate(input, estimate, &result);
  result.statistics.time_ms = timer.ms();
  return result;
}

std::size_t applyWindowResult(const WindowBundleResult& result, map::Map& map) {
  std::size_t written = 0;
  for (const BundleKeyframe& kf : result.keyframes) {
    if (kf.fixed || !map.hasKeyframe(kf.id)) continue;
    map.keyframe(kf.id).T_kf_world = kf.T_kf_world;
    ++written;
  }
  for (const BundlePoint& p : result.points) {
    if (p.fixed || !map.hasPoint(p.id)) continue;
    map.point(p.id).p_world = p.p_world;
    ++written;
  }
  map.bumpVersion();
  return written;
}

}  // namespace scale_drift_slam::mapping
