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
      input.observations.push_back({k, entry->second, obs.xy});
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

}  // namespace

WindowBundleResult solveWindowBundleAdjustment(const WindowBundleInput& input,
                                               const WindowBundleAdjustmentParams& params) {
  const common::Stopwatch timer;
  params.validate();
  input.validate();

  std::vector<std::array<double, 7>> poses(input.keyframes.size());
  for (std::size_t k = 0; k < input.keyframes.size(); ++k)
    input.keyframes[k].T_kf_world.toData(poses[k].data());
  std::vector<Eigen::Vector3d> points;
  points.reserve(input.points.size());
  for (const BundlePoint& p : input.points)
    points.push_back(p.p_world);
  const std::vector<double> initial_errors = pixelErrors(input, poses, points);

  // The problem borrows costs, kernel and manifold: they live on this stack frame.
  ceres::Problem::Options problem_options;
  problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  ceres::SoftLOneLoss pseudo_huber(params.huber_width_px);  // see features::pseudoHuber
  features::SE3LeftManifold se3_manifold;
  std::deque<features::ReprojectionCost> costs;  // stable addresses, no copies
  std::vector<bool> pose_used(poses.size(), false), point_used(points.size(), false);
  for (std::size_t i = 0; i < input.observations.size(); ++i) {
    if (!std::isfinite(initial_errors[i])) continue;
    const BundleObservation& o = input.observations[i];
    costs.emplace_back(o.xy, input.focal_length_px);
    problem.AddResidualBlock(&costs.back(), &pseudo_huber, poses[o.keyframe_index].data(),
                             points[o.point_index].data());
    pose_used[o.keyframe_index] = point_used[o.point_index] = true;
  }

  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  bool any_free = false;
  for (std::size_t k = 0; k < poses.size(); ++k) {
    if (!pose_used[k]) continue;
    problem.SetManifold(poses[k].data(), &se3_manifold);
    if (input.keyframes[k].fixed) problem.SetParameterBlockConstant(poses[k].data());
    any_free |= !input.keyframes[k].fixed;
    ordering->AddElementToGroup(poses[k].data(), 1);
  }
  for (std::size_t j = 0; j < points.size(); ++j) {
    if (!point_used[j]) continue;
    if (input.points[j].fixed) problem.SetParameterBlockConstant(points[j].data());
    any_free |= !input.points[j].fixed;
    ordering->AddElementToGroup(points[j].data(), 0);  // eliminated first (Schur complement)
  }

  WindowBundleResult result;
  features::BundleStatistics& stats = result.statistics;
  if (any_free && !costs.empty()) {
    ceres::Solver::Options options;
    options.linear_solver_type = ceres::SPARSE_SCHUR;
    options.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
    options.linear_solver_ordering = ordering;
    options.max_num_iterations = params.max_iterations;
    options.function_tolerance = params.function_tolerance;
    options.num_threads = params.num_threads;
    options.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    ceres::Solve(options, &problem, &summary);
    stats.iterations = static_cast<int>(summary.iterations.size()) - 1;
    stats.converged = summary.termination_type == ceres::CONVERGENCE;
    stats.message = summary.message;
  } else {
    stats.converged = true;
    stats.message = "nothing to optimise";
  }

  const std::vector<double> final_errors = pixelErrors(input, poses, points);
  stats.initial_cost = robustCost(initial_errors, params.huber_width_px);
  stats.final_cost = robustCost(final_errors, params.huber_width_px);
  stats.num_observations = input.observations.size();
  result.inlier.resize(input.observations.size());
  double initial_sq = 0.0, final_sq = 0.0;
  for (std::size_t i = 0; i < final_errors.size(); ++i) {
    result.inlier[i] = std::isfinite(final_errors[i]) && std::isfinite(initial_errors[i]) &&
                       final_errors[i] < params.inlier_threshold_px;
    if (!result.inlier[i]) continue;
    ++stats.num_inliers;
    initial_sq += initial_errors[i] * initial_errors[i];
    final_sq += final_errors[i] * final_errors[i];
  }
  if (stats.num_inliers > 0) {
    stats.initial_rmse_px = std::sqrt(initial_sq / stats.num_inliers);
    stats.final_rmse_px = std::sqrt(final_sq / stats.num_inliers);
  }

  result.keyframes = input.keyframes;
  for (std::size_t k = 0; k < poses.size(); ++k) {
    if (!input.keyframes[k].fixed)
      result.keyframes[k].T_kf_world = geometry::SE3::fromData(poses[k].data());
  }
  result.points = input.points;
  for (std::size_t j = 0; j < points.size(); ++j)
    result.points[j].p_world = points[j];
  stats.time_ms = timer.ms();
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
