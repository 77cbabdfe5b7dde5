#include "scale_drift_slam/features/motion_only_bundle_adjustment.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <stdexcept>

#include <ceres/ceres.h>
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "scale_drift_slam/common/stopwatch.h"

#include "scale_drift_slam/features/reprojection_cost.h"

namespace scale_drift_slam::features {

void MotionOnlyBundleAdjustmentParams::validate() const {
  auto fail = [](const std::string& what) {
    throw std::invalid_argument("motion-only bundle adjustment: " + what);
  };
  if (!(huber_width_px > 0.0)) fail("huber_width_px must be > 0");
  if (!(inlier_threshold_px > 0.0)) fail("inlier_threshold_px must be > 0");
  if (max_iterations < 1) fail("max_iterations must be >= 1");
  if (!(min_step_norm >= 0.0)) fail("min_step_norm must be >= 0");
  if (!(function_tolerance >= 0.0)) fail("function_tolerance must be >= 0");
}

void MotionOnlyInput::validate() const {
  if (!(focal_length_px > 0.0) || !std::isfinite(focal_length_px)) {
    throw std::invalid_argument("motion-only bundle adjustment: focal length must be > 0");
  }
  if (!T_cam_world_guess.translation().allFinite() ||
      !T_cam_world_guess.rotation().coeffs().allFinite()) {
    throw std::invalid_argument("motion-only bundle adjustment: the pose guess is not finite");
  }
  for (const PoseObservation& o : observations) {
    if (!o.p_world.allFinite() || !o.xy.allFinite()) {
      throw std::invalid_argument("motion-only bundle adjustment: an observation is not finite");
    }
  }
}

namespace {

/// A point behind the camera costs as much as a 1000 px error: it still counts in the cost, so
/// a step that moves points behind the camera is rejected.
constexpr double kBehindErrorPx = 1000.0;

struct NormalEquations {
  Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
  double cost = 0.0;
  int num_in_front = 0;
};

/// sum rho and, when `with_jacobians`, the reweighted normal equations
/// H = sum w J^T J, g = sum w J^T r with w = rho'(|r|^2) = 1 / sqrt(1 + |r|^2 / b^2) (IRLS).
NormalEquations evaluate(const MotionOnlyInput& input, const geometry::SE3& T, double width,
                         bool with_jacobians) {
  NormalEquations ne;
  Eigen::Vector2d r;
  Eigen::Matrix<double, 2, 6> J;
  for (const PoseObservation& o : input.observations) {
    if (!features::reprojectionResidual(T, o.p_world, o.xy, input.focal_length_px, &r,
                                        with_jacobians ? &J : nullptr, nullptr)) {
      ne.cost += features::pseudoHuber(kBehindErrorPx * kBehindErrorPx, width);
      continue;
    }
    ++ne.num_in_front;
    const double s = r.squaredNorm();
    ne.cost += features::pseudoHuber(s, width);
    if (!with_jacobians) continue;
    const double w = 1.0 / std::sqrt(1.0 + s / (width * width));
    ne.H.noalias() += w * J.transpose() * J;
    ne.g.noalias() += w * J.transpose() * r;
  }
  return ne;
}

/// Levenberg-Marquardt on the 6-DoF left update T <- exp(delta) T (doc/algorithm.md,
/// "Notation": accept a step only if it lowers the cost, then lower the damping mu, else raise
/// it). The damping is mu * diag(H) (Marquardt's scaling).
geometry::SE3 handWrittenLm(const MotionOnlyInput& input,
                            const MotionOnlyBundleAdjustmentParams& params,
                            BundleStatistics* stats) {
  geometry::SE3 T = input.T_cam_world_guess;
  NormalEquations ne = evaluate(input, T, params.huber_width_px, true);
  double mu = 1e-4;
  for (int iteration = 0; iteration < params.max_iterations; ++iteration) {
    ++stats->iterations;
    bool accepted = false;
    for (int attempt = 0; attempt < 10 && !accepted; ++attempt) {
      Eigen::Matrix<double, 6, 6> A = ne.H;
      A.diagonal() += mu * ne.H.diagonal().cwiseMax(1e-9);
      const Eigen::Matrix<double, 6, 1> delta = -A.ldlt().solve(ne.g);
      if (!delta.allFinite()) break;
      const geometry::SE3 T_new = geometry::SE3::exp(delta) * T;
      const double cost_new = evaluate(input, T_new, params.huber_width_px, false).cost;
      if (cost_new < ne.cost) {
        accepted = true;
        const double decrease = (ne.cost - cost_new) / std::max(ne.cost, 1e-300);
        T = T_new;
        mu = std::max(mu * 0.1, 1e-12);
        ne = evaluate(input, T, params.huber_width_px, true);
        if (delta.norm() < params.min_step_norm || decrease < params.function_tolerance) {
          stats->converged = true;
          return T;
        }
      } else {
        mu *= 10.0;
      }
    }
    if (!accepted) {  // No step lowers the cost: at a minimum up to numerics.
      stats->converged = true;
      return T;
    }
  }
  return T;
}

geometry::SE3 ceresLm(const MotionOnlyInput& input, const MotionOnlyBundleAdjustmentParams& params,
                      BundleStatistics* stats) {
  ceres::Problem::Options problem_options;
  problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  ceres::SoftLOneLoss pseudo_huber(params.huber_width_px);  // see features::pseudoHuber
  features::SE3LeftManifold manifold;
  std::array<double, 7> pose;
  input.T_cam_world_guess.toData(pose.data());
  std::vector<Eigen::Vector3d> points;
  std::deque<features::ReprojectionCost> costs;  // stable addresses, no copies
  points.reserve(input.observations.size());
  for (const PoseObservation& o : input.observations) {
    if (!((input.T_cam_world_guess * o.p_world).z() > features::kMinDepth)) continue;
    points.push_back(o.p_world);
    costs.emplace_back(o.xy, input.focal_length_px);
    problem.AddResidualBlock(&costs.back(), &pseudo_huber, pose.data(), points.back().data());
    problem.SetParameterBlockConstant(points.back().data());
  }
  problem.SetManifold(pose.data(), &manifold);
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.max_num_iterations = params.max_iterations;
  options.function_tolerance = std::max(params.function_tolerance, 1e-16);
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  stats->iterations = static_cast<int>(summary.iterations.size()) - 1;
  stats->converged = summary.termination_type == ceres::CONVERGENCE;
  stats->message = summary.message;
  return geometry::SE3::fromData(pose.data());
}

}  // namespace

std::optional<Eigen::Matrix<double, 6, 6>> poseCovariance(
    const Eigen::Matrix<double, 6, 6>& information, double pixel_sigma_px) {
  if (!information.allFinite() || !(pixel_sigma_px > 0.0) || !std::isfinite(pixel_sigma_px)) {
    return std::nullopt;
  }
  // Eigenvalues, not a Cholesky test: a near-singular information (points on one ray) passes
  // Cholesky in floating point but gives a meaningless inverse.
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eigen(information);
  if (eigen.info() != Eigen::Success) return std::nullopt;
  const Eigen::Matrix<double, 6, 1> values = eigen.eigenvalues();
  if (!(values(0) > 1e-12 * std::max(values(5), 1e-300))) return std::nullopt;
  const Eigen::Matrix<double, 6, 6> V = eigen.eigenvectors();
  Eigen::Matrix<double, 6, 6> covariance =
      pixel_sigma_px * pixel_sigma_px * V * values.cwiseInverse().asDiagonal() * V.transpose();
  covariance = 0.5 * (covariance + covariance.transpose()).eval();
  return covariance;
}

MotionOnlyResult solveMotionOnlyBundleAdjustment(const MotionOnlyInput& input,
                                                 const MotionOnlyBundleAdjustmentParams& params) {
  const common::Stopwatch timer;
  params.validate();
  input.validate();
  const NormalEquations initial =
      evaluate(input, input.T_cam_world_guess, params.huber_width_px, false);
  if (initial.num_in_front < 3) {
    throw std::invalid_argument(
        "motion-only bundle adjustment needs >= 3 observations in front of the camera, got " +
        std::to_string(initial.num_in_front));
  }
  MotionOnlyResult result;
  BundleStatistics& stats = result.statistics;
  result.T_cam_world = params.solver == MotionOnlySolver::kCeres
                           ? ceresLm(input, params, &stats)
                           : handWrittenLm(input, params, &stats);
  const NormalEquations final_ne = evaluate(input, result.T_cam_world, params.huber_width_px, true);
  result.information = final_ne.H;
  stats.initial_cost = initial.cost;
  stats.final_cost = final_ne.cost;
  stats.num_observations = input.observations.size();
  result.inlier.resize(input.observations.size());
  double initial_sq = 0.0, final_sq = 0.0;
  for (std::size_t i = 0; i < input.observations.size(); ++i) {
    const PoseObservation& o = input.observations[i];
    Eigen::Vector2d r0 = Eigen::Vector2d::Zero(), r1 = Eigen::Vector2d::Zero();
    Eigen::Matrix<double, 2, 6> J;
    const bool ok0 = features::reprojectionResidual(input.T_cam_world_guess, o.p_world, o.xy,
                                                    input.focal_length_px, &r0, nullptr, nullptr);
    const bool ok1 = features::reprojectionResidual(result.T_cam_world, o.p_world, o.xy,
                                                    input.focal_length_px, &r1, &J, nullptr);
    result.inlier[i] = ok1 && r1.norm() < params.inlier_threshold_px;
    if (!result.inlier[i]) continue;
    ++stats.num_inliers;
    result.inlier_information.noalias() += J.transpose() * J;
    initial_sq += ok0 ? r0.squaredNorm() : kBehindErrorPx * kBehindErrorPx;
    final_sq += r1.squaredNorm();
  }
  if (stats.num_inliers > 0) {
    stats.initial_rmse_px = std::sqrt(initial_sq / stats.num_inliers);
    stats.final_rmse_px = std::sqrt(final_sq / stats.num_inliers);
  }
  stats.time_ms = timer.ms();
  return result;
}

std::optional<geometry::SE3> ransacPose(const MotionOnlyInput& input, const PnpRansacParams& ransac,
                                        std::vector<int>* inliers) {
  inliers->clear();
  if (input.observations.size() < 4 || !(input.focal_length_px > 0.0)) return std::nullopt;
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> normalised;
  for (const PoseObservation& o : input.observations) {
    object.emplace_back(o.p_world.x(), o.p_world.y(), o.p_world.z());
    normalised.emplace_back(o.xy.x(), o.xy.y());
  }
  cv::Mat rvec, tvec;
  try {
    if (!cv::solvePnPRansac(
            object, normalised, cv::Mat::eye(3, 3, CV_64F), cv::noArray(), rvec, tvec, false,
            ransac.iterations, ransac.threshold_px / input.focal_length_px, ransac.confidence,
            *inliers,
            ransac.solver == PnpSampleSolver::kP3P ? cv::SOLVEPNP_AP3P : cv::SOLVEPNP_EPNP) ||
        inliers->size() < 4) {
      inliers->clear();
      return std::nullopt;
    }
  } catch (const cv::Exception&) {  // degenerate points (all on one line, or coincident)
    inliers->clear();
    return std::nullopt;
  }
  cv::Mat R_cv;
  cv::Rodrigues(rvec, R_cv);
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  cv::cv2eigen(R_cv, R);
  cv::cv2eigen(tvec, t);
  if (!R.allFinite() || !t.allFinite()) return std::nullopt;
  return geometry::SE3(R, t);
}

std::optional<MotionOnlyResult> solvePoseWithoutGuess(
    const MotionOnlyInput& input, const PnpRansacParams& ransac,
    const MotionOnlyBundleAdjustmentParams& params, std::vector<int>* kept) {
  const std::optional<geometry::SE3> T = ransacPose(input, ransac, kept);
  if (!T) return std::nullopt;
  MotionOnlyInput on_inliers;
  on_inliers.T_cam_world_guess = *T;
  on_inliers.focal_length_px = input.focal_length_px;
  for (const int k : *kept)
    on_inliers.observations.push_back(input.observations[k]);
  try {
    return solveMotionOnlyBundleAdjustment(on_inliers, params);
  } catch (const std::invalid_argument&) {  // RANSAC's pose puts its own inliers behind it
    return std::nullopt;
  }
}

}  // namespace scale_drift_slam::features
