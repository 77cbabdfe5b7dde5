// The algebra adjoint and the left Jacobians of SE(3) and Sim(3) against first principles: the
// matrix commutator of hat(), and numeric derivatives of exp and log, in both evaluation
// branches (series and quadrature) and across the switch between them.

#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "scale_drift_slam/geometry/lie_jacobians.h"

namespace scale_drift_slam::geometry {
namespace {

template <typename Tangent>
Tangent randomTangent(std::mt19937& rng, double rotation, double scale, double translation) {
  std::normal_distribution<double> normal;
  Tangent xi;
  for (int i = 0; i < xi.size(); ++i) {
    xi[i] = normal(rng);
  }
  xi.template head<3>() = xi.template head<3>().normalized() * rotation;
  xi.template tail<3>() = xi.template tail<3>().normalized() * translation;
  if (xi.size() == 7) {
    xi[3] = scale;
  }
  return xi;
}

/// (rotation angle, log-scale) pairs covering the tiny, series and quadrature branches and the
/// switches at theta^2 + sigma^2 = 1e-4 and 0.25.
const std::vector<std::pair<double, double>> kMagnitudes = {
    {0.0, 0.0},   {1e-9, 0.0}, {1e-3, -2e-3}, {0.0099, 0.0}, {0.0101, 0.0}, {0.2, 0.3},
    {0.49, 0.05}, {0.51, 0.0}, {0.3, 0.45},   {1.0, -0.99},  {2.5, 0.99},   {3.1, -2.0}};

/// Central differences of f: R^N -> R^N at 0.
template <int N, typename F>
Eigen::Matrix<double, N, N> numericJacobian(const F& f) {
  Eigen::Matrix<double, N, N> J;
  const double h = 1e-6;
  for (int c = 0; c < N; ++c) {
    Eigen::Matrix<double, N, 1> d = Eigen::Matrix<double, N, 1>::Zero();
    d[c] = h;
    J.col(c) = (f(d) - f(-d)) / (2 * h);
  }
  return J;
}

TEST(LieJacobians, AdIsTheCommutatorOfHat) {
  std::mt19937 rng(3);
  for (int i = 0; i < 20; ++i) {
    const Sim3::Tangent a = randomTangent<Sim3::Tangent>(rng, 0.7, -0.4, 2.0);
    const Sim3::Tangent b = randomTangent<Sim3::Tangent>(rng, 1.3, 0.9, 0.5);
    const Eigen::Matrix4d commutator = Sim3::hat(a) * Sim3::hat(b) - Sim3::hat(b) * Sim3::hat(a);
    EXPECT_LT((adSim3(a) * b - Sim3::vee(commutator)).norm(), 1e-12);
    const SE3::Tangent c = randomTangent<SE3::Tangent>(rng, 0.7, 0.0, 2.0);
    const SE3::Tangent d = randomTangent<SE3::Tangent>(rng, 2.1, 0.0, 1.0);
    const Eigen::Matrix4d se3_commutator = SE3::hat(c) * SE3::hat(d) - SE3::hat(d) * SE3::hat(c);
    EXPECT_LT((adSE3(c) * d - SE3::vee(se3_commutator)).norm(), 1e-12);
  }
}

TEST(LieJacobians, StructuredProductEqualsTheDenseOne) {
  std::mt19937 rng(13);
  for (int i = 0; i < 10; ++i) {
    const Sim3::Tangent a = randomTangent<Sim3::Tangent>(rng, 2.0, 0.7, 3.0);
    const Sim3 S = Sim3::exp(randomTangent<Sim3::Tangent>(rng, 1.0, -0.4, 5.0));
    for (const auto& [X, Y] : {std::pair<Matrix7d, Matrix7d>{adSim3(a), S.adjoint()},
                               {inverseLeftJacobianSim3(a), S.adjoint()},
                               {leftJacobianSim3(a), adSim3(a)}}) {
      EXPECT_LT((multiplyTangentMaps(X, Y) - X * Y).norm(), 1e-12 * (X * Y).norm());
    }
    const SE3::Tangent b = randomTangent<SE3::Tangent>(rng, 2.0, 0.0, 3.0);
    const SE3 T = SE3::exp(randomTangent<SE3::Tangent>(rng, 1.0, 0.0, 5.0));
    const Matrix6d X = inverseLeftJacobianSE3(b), Y = T.adjoint();
    EXPECT_LT((multiplyTangentMaps(X, Y) - X * Y).norm(), 1e-12 * (X * Y).norm());
  }
}

TEST(LieJacobians, Sim3JacobiansMatchNumericDerivatives) {
  std::mt19937 rng(5);
  for (const auto& [theta, sigma] : kMagnitudes) {
    for (double translation : {0.0, 0.3, 4.0}) {
      const Sim3::Tangent xi = randomTangent<Sim3::Tangent>(rng, theta, sigma, translation);
      const Sim3 X = Sim3::exp(xi);
      // exp(xi + d) exp(xi)^-1 = exp(Jl d): d/dd log(...) = Jl.
      const Matrix7d numeric_jl = numericJacobian<7>(
          [&](const Sim3::Tangent& d) { return (Sim3::exp(xi + d) * X.inverse()).log(); });
      const Matrix7d jl = leftJacobianSim3(xi);
      EXPECT_LT((jl - numeric_jl).norm(), 1e-7 * std::max(1.0, jl.norm())) << xi.transpose();
      // log(exp(e) exp(xi)) = xi + Jl^-1 e.
      const Matrix7d numeric_inverse =
          numericJacobian<7>([&](const Sim3::Tangent& e) { return (Sim3::exp(e) * X).log(); });
      const Matrix7d inverse = inverseLeftJacobianSim3(xi);
      EXPECT_LT((inverse - numeric_inverse).norm(), 1e-7 * std::max(1.0, inverse.norm()))
          << xi.transpose();
      EXPECT_LT((jl * inverse - Matrix7d::Identity()).norm(), 1e-11 * std::max(1.0, jl.norm()))
          << xi.transpose();
    }
  }
}

TEST(LieJacobians, SE3JacobiansMatchNumericDerivatives) {
  std::mt19937 rng(7);
  for (const auto& magnitude : kMagnitudes) {
    for (double translation : {0.0, 0.3, 4.0}) {
      const SE3::Tangent xi = randomTangent<SE3::Tangent>(rng, magnitude.first, 0.0, translation);
      const SE3 X = SE3::exp(xi);
      const Matrix6d numeric_jl = numericJacobian<6>(
          [&](const SE3::Tangent& d) { return (SE3::exp(xi + d) * X.inverse()).log(); });
      const Matrix6d jl = leftJacobianSE3(xi);
      EXPECT_LT((jl - numeric_jl).norm(), 1e-7 * std::max(1.0, jl.norm())) << xi.transpose();
      const Matrix6d numeric_inverse =
          numericJacobian<6>([&](const SE3::Tangent& e) { return (SE3::exp(e) * X).log(); });
      const Matrix6d inverse = inverseLeftJacobianSE3(xi);
      EXPECT_LT((inverse - numeric_inverse).norm(), 1e-7 * std::max(1.0, inverse.norm()))
          << xi.transpose();
      EXPECT_LT((jl * inverse - Matrix6d::Identity()).norm(), 1e-11 * std::max(1.0, jl.norm()));
    }
  }
}

TEST(LieJacobians, BranchesAgreeAtTheirBoundaries) {
  // Just below and above each switch the two formulas must give the same matrix.
  std::mt19937 rng(11);
  for (double radius : {1e-2, 0.5}) {
    const Sim3::Tangent direction = randomTangent<Sim3::Tangent>(rng, 1.0, 0.0, 2.0);
    Sim3::Tangent below = direction, above = direction;
    below.head<3>() *= radius * (1 - 1e-13);
    above.head<3>() *= radius * (1 + 1e-13);
    EXPECT_LT((inverseLeftJacobianSim3(below) - inverseLeftJacobianSim3(above)).norm(), 1e-11);
    EXPECT_LT((leftJacobianSim3(below) - leftJacobianSim3(above)).norm(), 1e-11);
  }
}

}  // namespace
}  // namespace scale_drift_slam::geometry
