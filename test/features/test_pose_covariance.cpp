// The motion-only BA's pose covariance sigma^2 (J^T J)^-1: against (J^T J)^-1 from numeric
// Jacobians, against the spread of the solved pose over many noisy draws (Monte Carlo), shrinking
// with more points, and empty when the pose is not determined.

#include <random>

#include <gtest/gtest.h>

#include "scale_drift_slam/features/motion_only_bundle_adjustment.h"
#include "scale_drift_slam/features/reprojection_cost.h"

namespace scale_drift_slam::features {
namespace {

constexpr double kFocal = 400.0;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

geometry::SE3 truePose() {
  geometry::SE3::Tangent xi;
  xi << 0.3, -0.2, 0.1, 1.0, -2.0, 0.5;
  return geometry::SE3::exp(xi);
}

/// Points in front of the true camera (depth 2..10), their exact normalised observations.
std::vector<Eigen::Vector3d> scenePoints(const geometry::SE3& T_true, int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0), unit(0.0, 1.0);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < n; ++i) {
    const double depth = 2.0 + 8.0 * unit(rng);
    points.push_back(T_true.inverse() *
                     Eigen::Vector3d(0.7 * u(rng) * depth, 0.5 * u(rng) * depth, depth));
  }
  return points;
}

MotionOnlyInput observe(const geometry::SE3& T_true, const std::vector<Eigen::Vector3d>& points,
                        double noise_px, std::mt19937* rng) {
  std::normal_distribution<double> noise(0.0, noise_px / kFocal);
  MotionOnlyInput input;
  input.focal_length_px = kFocal;
  input.T_cam_world_guess = T_true;
  for (const Eigen::Vector3d& p : points) {
    const Eigen::Vector3d y = T_true * p;
    input.observations.push_back(
        {p, y.head<2>() / y.z() + Eigen::Vector2d(noise(*rng), noise(*rng))});
  }
  return input;
}

/// J^T J of the pixel residuals by central differences of the left update exp(delta) T.
Matrix6d numericInformation(const geometry::SE3& T, const MotionOnlyInput& input) {
  Matrix6d H = Matrix6d::Zero();
  const double h = 1e-6;
  for (const PoseObservation& o : input.observations) {
    Eigen::Matrix<double, 2, 6> J;
    for (int k = 0; k < 6; ++k) {
      geometry::SE3::Tangent d = geometry::SE3::Tangent::Zero();
      d(k) = h;
      Eigen::Vector2d plus = Eigen::Vector2d::Zero(), minus = Eigen::Vector2d::Zero();
      reprojectionResidual(geometry::SE3::exp(d) * T, o.p_world, o.xy, kFocal, &plus, nullptr,
                           nullptr);
      reprojectionResidual(geometry::SE3::exp(-d) * T, o.p_world, o.xy, kFocal, &minus, nullptr,
                           nullptr);
      J.col(k) = (plus - minus) / (2 * h);
    }
    H += J.transpose() * J;
  }
  return H;
}

TEST(PoseCovariance, IsSigmaSquaredTimesTheInverseOfNumericJtJ) {
  const geometry::SE3 T_true = truePose();
  std::mt19937 rng(5);
  const MotionOnlyInput input = observe(T_true, scenePoints(T_true, 80, 1), 0.5, &rng);
  const MotionOnlyResult result =
      solveMotionOnlyBundleAdjustment(input, MotionOnlyBundleAdjustmentParams());
  ASSERT_EQ(result.statistics.num_inliers, 80u);
  const Matrix6d H = numericInformation(result.T_cam_world, input);
  EXPECT_LT((result.inlier_information - H).norm(), 1e-5 * H.norm());
  const std::optional<Matrix6d> covariance = poseCovariance(result.inlier_information, 1.5);
  ASSERT_TRUE(covariance);
  const Matrix6d expected = 2.25 * H.inverse();
  EXPECT_LT((*covariance - expected).norm(), 1e-6 * expected.norm());
  EXPECT_LT((*covariance - covariance->transpose()).norm(), 1e-15 * expected.norm());
}

TEST(PoseCovariance, MatchesTheSpreadOfSolvedPoses) {
  // 400 draws of 1 px noise: the sample covariance of the error log(T_est T_true^-1) against the
  // predicted one. Pseudo-Huber (b = 2 px) is close to least squares at 1 px: within 20 %.
  const geometry::SE3 T_true = truePose();
  const std::vector<Eigen::Vector3d> points = scenePoints(T_true, 60, 2);
  std::mt19937 rng(7);
  Matrix6d sample = Matrix6d::Zero();
  const int draws = 400;
  for (int i = 0; i < draws; ++i) {
    const MotionOnlyResult result = solveMotionOnlyBundleAdjustment(
        observe(T_true, points, 1.0, &rng), MotionOnlyBundleAdjustmentParams());
    const geometry::SE3::Tangent e = (result.T_cam_world * T_true.inverse()).log();
    sample += e * e.transpose() / draws;
  }
  std::mt19937 exact_rng(0);
  const Matrix6d predicted =
      *poseCovariance(numericInformation(T_true, observe(T_true, points, 0.0, &exact_rng)), 1.0);
  for (int k = 0; k < 6; ++k) {
    EXPECT_NEAR(sample(k, k) / predicted(k, k), 1.0, 0.2) << "component " << k;
  }
  // The whole matrix: the whitened sample covariance is near the identity.
  const Eigen::LLT<Matrix6d> llt(predicted);
  const Eigen::Matrix<double, 6, 6> L_inv = Eigen::Matrix<double, 6, 6>(llt.matrixL()).inverse();
  const Matrix6d whitened = L_inv * sample * L_inv.transpose();
  EXPECT_LT((whitened - Matrix6d::Identity()).norm(), 0.5) << whitened;
}

TEST(PoseCovariance, ShrinksWithMorePoints) {
  const geometry::SE3 T_true = truePose();
  std::mt19937 rng(3);
  const std::vector<Eigen::Vector3d> many = scenePoints(T_true, 400, 4);
  const std::vector<Eigen::Vector3d> few(many.begin(), many.begin() + 25);
  const MotionOnlyBundleAdjustmentParams params;
  const Matrix6d Sigma_few = *poseCovariance(
      solveMotionOnlyBundleAdjustment(observe(T_true, few, 1.0, &rng), params).inlier_information,
      1.0);
  const Matrix6d Sigma_many = *poseCovariance(
      solveMotionOnlyBundleAdjustment(observe(T_true, many, 1.0, &rng), params).inlier_information,
      1.0);
  // Sigma_few - Sigma_many is positive semi-definite (the many include the few), and with 16x
  // the points the variances are several times smaller.
  const Eigen::SelfAdjointEigenSolver<Matrix6d> difference(Sigma_few - Sigma_many);
  EXPECT_GT(difference.eigenvalues().minCoeff(), 0.0);
  EXPECT_LT(Sigma_many.trace(), Sigma_few.trace() / 5.0);
}

TEST(PoseCovariance, EmptyWhenThePoseIsNotDetermined) {
  EXPECT_FALSE(poseCovariance(Matrix6d::Zero(), 1.0));
  // Two points: rank 4.
  const geometry::SE3 T_true = truePose();
  std::mt19937 rng(1);
  const MotionOnlyInput input = observe(T_true, scenePoints(T_true, 2, 9), 0.0, &rng);
  Matrix6d H = Matrix6d::Zero();
  for (const PoseObservation& o : input.observations) {
    Eigen::Vector2d r;
    Eigen::Matrix<double, 2, 6> J;
    ASSERT_TRUE(reprojectionResidual(T_true, o.p_world, o.xy, kFocal, &r, &J, nullptr));
    H += J.transpose() * J;
  }
  EXPECT_FALSE(poseCovariance(H, 1.0));
  Matrix6d not_finite = Matrix6d::Identity();
  not_finite(2, 2) = std::nan("");
  EXPECT_FALSE(poseCovariance(not_finite, 1.0));
  EXPECT_FALSE(poseCovariance(Matrix6d::Identity(), 0.0));
}

}  // namespace
}  // namespace scale_drift_slam::features
