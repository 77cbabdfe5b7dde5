#include "scale_drift_slam/mapping/structure_only_ba.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "scale_drift_slam/common/stopwatch.h"

namespace scale_drift_slam::mapping {
namespace {

/// A point must be this far in front of a camera (in its units) to be projected.
constexpr double kMinDepth = 1e-9;

/// A pose as plain numbers: R row-major, then t (the hot loop reads them in this order).
struct PoseRt {
  double R[9];
  double t[3];
};

/// The kernel and the pixel scaling, fixed for one run.
struct Kernel {
  double fx, fy;  ///< |fx|, |fy|.
  double b_sq;    ///< b^2 of the pseudo-Huber kernel.
  double inv_b_sq;
  bool robust;
  double behind_cost;

  /// rho(s), and its derivative rho'(s) (the IRLS weight).
  double cost(double s, double* weight) const {
    if (!robust) {
      *weight = 1.0;
      return s;
    }
    const double root = std::sqrt(1.0 + s * inv_b_sq);
    *weight = 1.0 / root;
    return 2.0 * b_sq * (root - 1.0);
  }
};

/// The cost of one point and the IRLS normal equations H dx = -g at x (H symmetric, stored as
/// its upper triangle h00 h01 h02 h11 h12 h22).
struct Linearisation {
  double h[6] = {0, 0, 0, 0, 0, 0};
  double g[3] = {0, 0, 0};
  double cost = 0.0;
  int in_front = 0;
};

/// Residual e = F (pi(R x + t) - z) and its Jacobian J = F [1 0 -u; 0 1 -v] R / z, written out:
/// this loop runs ~10^6 times per structure-only BA of the Keble map.
Linearisation linearise(const Eigen::Vector3d& x, const StructureOnlyProblem::Observation* begin,
                        const StructureOnlyProblem::Observation* end,
                        const std::vector<PoseRt>& poses, const Kernel& kernel) {
  Linearisation lin;
  const double x0 = x.x(), x1 = x.y(), x2 = x.z();
  for (const auto* obs = begin; obs != end; ++obs) {
    const PoseRt& pose = poses[obs->pose];
    const double* R = pose.R;
    const double pz = R[6] * x0 + R[7] * x1 + R[8] * x2 + pose.t[2];
    if (!(pz > kMinDepth)) {
      lin.cost += kernel.behind_cost;
      continue;
    }
    ++lin.in_front;
    const double px = R[0] * x0 + R[1] * x1 + R[2] * x2 + pose.t[0];
    const double py = R[3] * x0 + R[4] * x1 + R[5] * x2 + pose.t[1];
    const double inv_z = 1.0 / pz;
    const double u = px * inv_z, v = py * inv_z;
    const double ex = kernel.fx * (u - obs->xy.x()), ey = kernel.fy * (v - obs->xy.y());
    double w;
    lin.cost += kernel.cost(ex * ex + ey * ey, &w);
    const double sx = kernel.fx * inv_z, sy = kernel.fy * inv_z;
    const double a0 = sx * (R[0] - u * R[6]), a1 = sx * (R[1] - u * R[7]),
                 a2 = sx * (R[2] - u * R[8]);
    const double b0 = sy * (R[3] - v * R[6]), b1 = sy * (R[4] - v * R[7]),
                 b2 = sy * (R[5] - v * R[8]);
    const double wa0 = w * a0, wa1 = w * a1, wa2 = w * a2;
    const double wb0 = w * b0, wb1 = w * b1, wb2 = w * b2;
    lin.h[0] += wa0 * a0 + wb0 * b0;
    lin.h[1] += wa0 * a1 + wb0 * b1;
    lin.h[2] += wa0 * a2 + wb0 * b2;
    lin.h[3] += wa1 * a1 + wb1 * b1;
    lin.h[4] += wa1 * a2 + wb1 * b2;
    lin.h[5] += wa2 * a2 + wb2 * b2;
    lin.g[0] += wa0 * ex + wb0 * ey;
    lin.g[1] += wa1 * ex + wb1 * ey;
    lin.g[2] += wa2 * ex + wb2 * ey;
  }
  return lin;
}

/// Solves (H + mu diag(H)) dx = -g by an LDL^T factorisation written out for 3x3; false when
/// the damped matrix is not positive definite.
bool solveDamped(const Linearisation& lin, double mu, Eigen::Vector3d* dx) {
  const double scale = 1.0 + mu;
  const double a00 = lin.h[0] * scale, a11 = lin.h[3] * scale, a22 = lin.h[5] * scale;
  const double tiny = 1e-14 * (a00 + a11 + a22);
  const double d0 = a00;
  if (!(d0 > tiny)) {
    return false;
  }
  const double l10 = lin.h[1] / d0, l20 = lin.h[2] / d0;
  const double d1 = a11 - l10 * lin.h[1];
  if (!(d1 > tiny)) {
    return false;
  }
  const double l21 = (lin.h[4] - l20 * lin.h[1]) / d1;
  const double d2 = a22 - l20 * lin.h[2] - l21 * l21 * d1;
  if (!(d2 > tiny)) {
    return false;
  }
  // L y = -g, D z = y, L^T dx = z.
  const double y0 = -lin.g[0], y1 = -lin.g[1] - l10 * y0, y2 = -lin.g[2] - l20 * y0 - l21 * y1;
  const double z2 = y2 / d2, z1 = y1 / d1 - l21 * z2, z0 = y0 / d0 - l10 * z1 - l20 * z2;
  *dx = Eigen::Vector3d(z0, z1, z2);
  return dx->allFinite();
}

struct PointOutcome {
  double initial_cost = 0.0;
  double final_cost = 0.0;
  int iterations = 0;
  bool skipped = false;
};

/// Levenberg-Marquardt on one point: (H + mu diag(H)) dx = -g, a step is taken only when it
/// lowers the cost (then mu shrinks), otherwise mu grows and the step is retried (at most ten
/// times per iteration). The linearisation of an accepted trial point is reused.
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
      if (solveDamped(lin, mu, &dx)) {
        const Linearisation trial = linearise(x + dx, begin, end, poses, kernel);
        if (trial.cost < lin.cost && trial.in_front >= 2) {
          x += dx;
          lin = trial;
          mu = std::max(mu / 3.0, 1e-12);
          accepted = true;
          break;
        }
      }
      mu *= 10.0;
    }
    if (!accepted) {
      break;  // no step lowers the cost: a minimum at machine precision
    }
    if (dx.norm() < options.step_tolerance * (x.norm() + options.step_tolerance)) {
      break;
    }
    if (previous_cost - lin.cost <= options.function_tolerance * previous_cost) {
      break;
    }
  }
  outcome.final_cost = lin.cost;
  return outcome;
}

std::vector<PoseRt> posesAsMatrices(const std::vector<geometry::SE3>& T_cam_world) {
  std::vector<PoseRt> poses;
  poses.reserve(T_cam_world.size());
  for (const geometry::SE3& T : T_cam_world) {
    PoseRt pose;
    Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(pose.R) = T.rotationMatrix();
    Eigen::Map<Eigen::Vector3d>(pose.t) = T.translation();
    poses.push_back(pose);
  }
  return poses;
}

ReprojectionStats statsOf(std::vector<double>& errors, std::size_t behind) {
  ReprojectionStats stats;
  stats.observations = errors.size() + behind;
  stats.behind = behind;
  if (errors.empty()) {
    return stats;
  }
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
      const PoseRt& pose = poses[obs.pose];
      const Eigen::Vector3d p =
          Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(pose.R) *
              problem.points[i] +
          Eigen::Map<const Eigen::Vector3d>(pose.t);
      if (!(p.z() > kMinDepth)) {
        ++behind;
        continue;
      }
      const Eigen::Vector2d d = p.head<2>() / p.z() - obs.xy;
      errors.push_back(
          std::sqrt(focal.x() * focal.x() * d.x() * d.x() + focal.y() * focal.y() * d.y() * d.y()));
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
  if (max_iterations < 1) {
    fail("max_iterations must be >= 1");
  }
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
  if (first_observation.size() != points.size() + 1) {
    fail("first_observation needs points + 1");
  }
  if (first_observation.front() != 0 || first_observation.back() != observations.size()) {
    fail("first_observation must run from 0 to the number of observations");
  }
  for (std::size_t i = 0; i + 1 < first_observation.size(); ++i) {
    if (first_observation[i] > first_observation[i + 1]) {
      fail("first_observation must not fall");
    }
  }
  for (const Observation& obs : observations) {
    if (obs.pose >= T_cam_world.size()) {
      fail("observation of pose " + std::to_string(obs.pose));
    }
    if (!obs.xy.allFinite()) {
      fail("non-finite observation");
    }
  }
  for (const Eigen::Vector3d& p : points) {
    if (!p.allFinite()) {
      fail("non-finite point");
    }
  }
}

StructureOnlyBAResult refineStructure(StructureOnlyProblem& problem,
                                      const Eigen::Vector2d& focal_length_px,
                                      const StructureOnlyBAOptions& options) {
  const common::Stopwatch timer;
  options.validate();
  problem.validate();
  checkFocal(focal_length_px);
  const Eigen::Vector2d focal = focal_length_px.cwiseAbs();
  const std::vector<PoseRt> poses = posesAsMatrices(problem.T_cam_world);
  const double b_sq = options.huber_width_px * options.huber_width_px;
  Kernel kernel{focal.x(), focal.y(), b_sq, 1.0 / b_sq, options.robust, 0.0};
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
  result.time_s = timer.seconds();
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
      const Eigen::Vector2d d = p.head<2>() / p.z() - obs.xyd();
      errors.push_back(
          std::sqrt(focal.x() * focal.x() * d.x() * d.x() + focal.y() * focal.y() * d.y() * d.y()));
    }
  }
  return statsOf(errors, behind);
}

}  // namespace scale_drift_slam::mapping
