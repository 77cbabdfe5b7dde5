#include "scale_drift_slam/mapping/structure_only_ba.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include <Eigen/Cholesky>

namespace scale_drift_slam::mapping {
namespace {

/// A point must be this far in front of a camera (in its units) to be projected.
constexpr double kMinDepth = 1e-9;

struct PoseRt {
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
};

/// The kernel and the pixel scaling, fixed for one run.
struct Kernel {
  double fx, fy;  ///< |fx|, |fy|.
  double b_sq;    ///< b^2 of the pseudo-Huber kernel.
  bool robust;
  double behind_cost;

  /// rho(s) and its derivative rho'(s) (the IRLS weight).
  double cost(double s, double* weight) const {
    if (!robust) {
      *weight = 1.0;
      return s;
    }
    const double root = std::sqrt(1.0 + s / b_sq);
    *weight = 1.0 / root;
    return 2.0 * b_sq * (root - 1.0);
  }
};

/// The cost of one point, and with `H`/`g` the IRLS normal equations H dx = -g at x.
struct Linearisation {
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  Eigen::Vector3d g = Eigen::Vector3d::Zero();
  double cost = 0.0;
  int in_front = 0;
};

Linearisation linearise(const Eigen::Vector3d& x, const StructureOnlyProblem::Observation* begin,
                        const StructureOnlyProblem::Observation* end,
                        const std::vector<PoseRt>& poses, const Kernel& kernel) {
  Linearisation lin;
  for (const auto* obs = begin; obs != end; ++obs) {
    const PoseRt& pose = poses[obs->pose];
    const Eigen::Vector3d p = pose.R * x + pose.t;
    if (!(p.z() > kMinDepth)) {
      lin.cost += kernel.behind_cost;
      continue;
    }
    ++lin.in_front;
    const double inv_z = 1.0 / p.z();
    const double u = p.x() * inv_z, v = p.y() * inv_z;
    const Eigen::Vector2d e(kernel.fx * (u - obs->xy.x()), kernel.fy * (v - obs->xy.y()));
    double w;
    lin.cost += kernel.cost(e.squaredNorm(), &w);
    // J = F d pi / d p R, d pi / d p = [1 0 -u; 0 1 -v] / z.
    Eigen::Matrix<double, 2, 3> dpi;
    dpi << kernel.fx * inv_z, 0.0, -kernel.fx * inv_z * u, 0.0, kernel.fy * inv_z,
        -kernel.fy * inv_z * v;
    const Eigen::Matrix<double, 2, 3> J = dpi * pose.R;
    lin.H.noalias() += w * J.transpose() * J;
    lin.g.noalias() += w * J.transpose() * e;
  }
  return lin;
}

struct PointOutcome {
  double initial_cost = 0.0;
  double final_cost = 0.0;
  int iterations = 0;
  bool skipped = false;
};

/// Levenberg-Marquardt on one point: (H + mu diag(H)) dx = -g, a step is taken only when it
/// lowers the cost (then mu shrinks), otherwise mu grows and the step is retried (at most ten
/// times per iteration).
PointOutcome refinePoint(Eigen::Vector3d& x, const StructureOnlyProblem::Observation* begin,
                         const StructureOnlyProblem::Observation* end,
                         const std::vector<PoseRt>& poses, const Kernel& kernel,
                         const StructureOnlyBAOptions& options) {
  PointOutcome outcome;
  Linearisation lin = linearise(x, begin, end, poses, kernel);
  outcome.initial_cost = outcome.final_cost = lin.cost;
  if (lin.in_front < 2) {
    outcome.skipped = true;
    return outcome;
  }
  double mu = options.initial_damping;
  while (outcome.iterations < options.max_iterations) {
    ++outcome.iterations;
    bool accepted = false;
    const double previous_cost = lin.cost;
    Eigen::Vector3d dx = Eigen::Vector3d::Zero();
    for (int attempt = 0; attempt < 10 && !accepted; ++attempt) {
      Eigen::Matrix3d A = lin.H;
      A.diagonal() *= 1.0 + mu;
      const Eigen::LLT<Eigen::Matrix3d> llt(A);
      if (llt.info() == Eigen::Success) {
        dx = -llt.solve(lin.g);
        Linearisation trial = linearise(x + dx, begin, end, poses, kernel);
        if (dx.allFinite() && trial.cost < lin.cost && trial.in_front >= 2) {
          x += dx;
          lin = trial;
          mu = std::max(mu / 3.0, 1e-12);
          accepted = true;
          break;
        }
      }
      mu *= 10.0;
    }
    if (!accepted) break;  // no step lowers the cost: a minimum at machine precision
    if (dx.norm() < options.step_tolerance * (x.norm() + options.step_tolerance)) break;
    if (previous_cost - lin.cost <= options.function_tolerance * previous_cost) break;
  }
  outcome.final_cost = lin.cost;
  return outcome;
}

std::vector<PoseRt> posesAsMatrices(const std::vector<geometry::SE3>& T_cam_world) {
  std::vector<PoseRt> poses;
  poses.reserve(T_cam_world.size());
  for (const geometry::SE3& T : T_cam_world)
    poses.push_back({T.rotationMatrix(), T.translation()});
  return poses;
}

ReprojectionStats statsOf(std::vector<double>& errors, std::size_t behind) {
  ReprojectionStats stats;
  stats.observations = errors.size() + behind;
  stats.behind = behind;
  if (errors.empty()) return stats;
  double sum = 0.0, sum_sq = 0.0;
  for (double e : errors) {
    sum += e;
    sum_sq += e * e;
  }
  stats.mean = sum / errors.size();
  stats.rms = std::sqrt(sum_sq / errors.size());
  auto quantile = [&errors](double q) {
    const std::size_t k = std::min(errors.size() - 1, static_cast<std::size_t>(q * errors.size()));
    std::nth_element(errors.begin(), errors.begin() + k, errors.end());
    return errors[k];
  };
  stats.median = quantile(0.5);
  stats.p90 = quantile(0.9);
  return stats;
}

ReprojectionStats problemStats(const StructureOnlyProblem& problem,
                               const std::vector<PoseRt>& poses, const Eigen::Vector2d& focal) {
  std::vector<double> errors;
  errors.reserve(problem.observations.size());
  std::size_t behind = 0;
  for (std::size_t i = 0; i < problem.points.size(); ++i) {
    for (std::size_t k = problem.first_observation[i]; k < problem.first_observation[i + 1]; ++k) {
      const auto& obs = problem.observations[k];
      const Eigen::Vector3d p = poses[obs.pose].R * problem.points[i] + poses[obs.pose].t;
      if (!(p.z() > kMinDepth)) {
        ++behind;
        continue;
      }
      const Eigen::Vector2d d = p.head<2>() / p.z() - obs.xy;
      errors.push_back(std::hypot(focal.x() * d.x(), focal.y() * d.y()));
    }
  }
  return statsOf(errors, behind);
}

void checkFocal(const Eigen::Vector2d& focal_length_px) {
  if (!focal_length_px.allFinite() || focal_length_px.x() == 0.0 || focal_length_px.y() == 0.0) {
    throw std::invalid_argument("structure-only BA: focal length must be finite and non-zero");
  }
}

}  // namespace

void StructureOnlyBAOptions::validate() const {
  auto fail = [](const std::string& what) {
    throw std::invalid_argument("structure-only BA: " + what);
  };
  if (max_iterations < 1) fail("max_iterations must be >= 1");
  if (!(huber_width_px > 0.0) || !std::isfinite(huber_width_px)) {
    fail("huber_width_px must be finite and > 0");
  }
  if (!(initial_damping > 0.0) || !std::isfinite(initial_damping)) {
    fail("initial_damping must be finite and > 0");
  }
  if (!(step_tolerance >= 0.0) || !std::isfinite(step_tolerance)) {
    fail("step_tolerance must be finite and >= 0");
  }
  if (!(function_tolerance >= 0.0) || !std::isfinite(function_tolerance)) {
    fail("function_tolerance must be finite and >= 0");
  }
  if (!(behind_camera_residual_px > 0.0) || !std::isfinite(behind_camera_residual_px)) {
    fail("behind_camera_residual_px must be finite and > 0");
  }
}

void StructureOnlyProblem::validate() const {
  auto fail = [](const std::string& what) {
    throw std::invalid_argument("structure-only problem: " + what);
  };
  if (first_observation.size() != points.size() + 1) fail("first_observation needs points + 1");
  if (first_observation.front() != 0 || first_observation.back() != observations.size()) {
    fail("first_observation must run from 0 to the number of observations");
  }
  for (std::size_t i = 0; i + 1 < first_observation.size(); ++i) {
    if (first_observation[i] > first_observation[i + 1]) fail("first_observation must not fall");
  }
  for (const Observation& obs : observations) {
    if (obs.pose >= T_cam_world.size()) fail("observation of pose " + std::to_string(obs.pose));
    if (!obs.xy.allFinite()) fail("non-finite observation");
  }
  for (const Eigen::Vector3d& p : points) {
    if (!p.allFinite()) fail("non-finite point");
  }
}

StructureOnlyBAResult refineStructure(StructureOnlyProblem& problem,
                                      const Eigen::Vector2d& focal_length_px,
                                      const StructureOnlyBAOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  options.validate();
  problem.validate();
  checkFocal(focal_length_px);
  const Eigen::Vector2d focal = focal_length_px.cwiseAbs();
  const std::vector<PoseRt> poses = posesAsMatrices(problem.T_cam_world);
  Kernel kernel{focal.x(), focal.y(), options.huber_width_px * options.huber_width_px,
                options.robust, 0.0};
  double unused_weight;
  kernel.behind_cost = kernel.cost(
      options.behind_camera_residual_px * options.behind_camera_residual_px, &unused_weight);

  StructureOnlyBAResult result;
  result.observations = problem.observations.size();
  result.before = problemStats(problem, poses, focal);
  long total_iterations = 0;
  for (std::size_t i = 0; i < problem.points.size(); ++i) {
    const auto* begin = problem.observations.data() + problem.first_observation[i];
    const auto* end = problem.observations.data() + problem.first_observation[i + 1];
    const PointOutcome outcome = refinePoint(problem.points[i], begin, end, poses, kernel, options);
    result.initial_cost += outcome.initial_cost;
    result.final_cost += outcome.final_cost;
    if (outcome.skipped) {
      ++result.points_skipped;
      continue;
    }
    ++result.points;
    total_iterations += outcome.iterations;
    result.max_iterations_used = std::max(result.max_iterations_used, outcome.iterations);
  }
  result.mean_iterations =
      result.points > 0 ? static_cast<double>(total_iterations) / result.points : 0.0;
  result.after = problemStats(problem, poses, focal);
  result.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

StructureOnlyBAResult refineStructure(map::Map& map, const std::vector<map::PointId>& points,
                                      const Eigen::Vector2d& focal_length_px,
                                      const StructureOnlyBAOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  std::vector<map::PointId> ids = points;
  if (ids.empty()) {
    ids.reserve(map.numPoints());
    for (const auto& entry : map.points())
      ids.push_back(entry.first);
    std::sort(ids.begin(), ids.end());
  }
  StructureOnlyProblem problem;
  std::unordered_map<map::KeyframeId, std::size_t> pose_index;
  for (const auto& [id, keyframe] : map.keyframes()) {
    pose_index.emplace(id, problem.T_cam_world.size());
    problem.T_cam_world.push_back(keyframe.T_kf_world);
  }
  // Observations grouped by point: each keyframe's observation list is scanned once.
  std::unordered_map<map::PointId, std::size_t> point_index;
  problem.first_observation.assign(ids.size() + 1, 0);
  for (std::size_t i = 0; i < ids.size(); ++i) {
    if (!point_index.emplace(ids[i], i).second) {
      throw std::invalid_argument("structure-only BA: point " + std::to_string(ids[i]) +
                                  " listed twice");
    }
    problem.points.push_back(map.point(ids[i]).p_world);  // throws for an unknown id
  }
  for (const auto& [id, keyframe] : map.keyframes()) {
    for (const map::Observation& obs : keyframe.observations) {
      const auto it = point_index.find(obs.point_id);
      if (it != point_index.end()) ++problem.first_observation[it->second + 1];
    }
  }
  for (std::size_t i = 0; i < ids.size(); ++i) {
    problem.first_observation[i + 1] += problem.first_observation[i];
  }
  problem.observations.resize(problem.first_observation.back());
  std::vector<std::size_t> fill(problem.first_observation.begin(),
                                problem.first_observation.end() - 1);
  for (const auto& [id, keyframe] : map.keyframes()) {
    for (const map::Observation& obs : keyframe.observations) {
      const auto it = point_index.find(obs.point_id);
      if (it != point_index.end())
        problem.observations[fill[it->second]++] = {pose_index[id], obs.xy};
    }
  }
  StructureOnlyBAResult result = refineStructure(problem, focal_length_px, options);
  for (std::size_t i = 0; i < ids.size(); ++i)
    map.point(ids[i]).p_world = problem.points[i];
  map.bumpVersion();
  result.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

ReprojectionStats reprojectionStats(const map::Map& map, const Eigen::Vector2d& focal_length_px) {
  checkFocal(focal_length_px);
  const Eigen::Vector2d focal = focal_length_px.cwiseAbs();
  std::vector<double> errors;
  errors.reserve(map.numObservations());
  std::size_t behind = 0;
  for (const auto& [id, keyframe] : map.keyframes()) {
    for (const map::Observation& obs : keyframe.observations) {
      const Eigen::Vector3d p = keyframe.T_kf_world * map.point(obs.point_id).p_world;
      if (!(p.z() > kMinDepth)) {
        ++behind;
        continue;
      }
      const Eigen::Vector2d d = p.head<2>() / p.z() - obs.xy;
      errors.push_back(std::hypot(focal.x() * d.x(), focal.y() * d.y()));
    }
  }
  return statsOf(errors, behind);
}

}  // namespace scale_drift_slam::mapping
