// SE(3) and Sim(3) against first principles: the matrix exponential of hat(xi), group axioms,
// the adjoint identity, and Ceres autodiff through exp/log against numeric differentiation.

#include <cmath>
#include <random>
#include <vector>

#include <ceres/jet.h>
#include <gtest/gtest.h>
#include <unsupported/Eigen/MatrixFunctions>

#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/geometry/sim3.h"

namespace scale_drift_slam::geometry {
namespace {

/// Rotation magnitudes that exercise every branch: zero, the Taylor series, the closed forms,
/// and the neighbourhood of theta = pi.
const std::vector<double> kAngles = {0.0, 1e-12, 1e-8, 1e-5,        1e-3,        0.02,
                                     0.5, 2.0,   3.0,  M_PI - 1e-3, M_PI - 1e-7, M_PI};
/// Log-scales: zero, tiny, small and large (the Keble loop has sigma = 0.99).
const std::vector<double> kSigmas = {0.0, 1e-12, -1e-7, 1e-4, -0.02, 0.3, 0.99, -2.5, 5.0};

Eigen::Vector3d randomAxis(std::mt19937& rng) {
  std::normal_distribution<double> normal;
  return Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
}

Eigen::Vector3d randomVector(std::mt19937& rng, double magnitude) {
  return randomAxis(rng) * magnitude;
}

std::vector<Sim3::Tangent> sim3Samples() {
  std::mt19937 rng(42);
  std::vector<Sim3::Tangent> samples;
  for (double theta : kAngles) {
    for (double sigma : kSigmas) {
      for (double upsilon : {0.0, 1e-6, 1.0, 7.5}) {
        Sim3::Tangent xi;
        xi << randomVector(rng, theta), sigma, randomVector(rng, upsilon);
        samples.push_back(xi);
      }
    }
  }
  return samples;
}

std::vector<SE3::Tangent> se3Samples() {
  std::vector<SE3::Tangent> samples;
  for (const Sim3::Tangent& xi : sim3Samples()) {
    if (xi[3] != 0.0) continue;
    SE3::Tangent v;
    v << xi.head<3>(), xi.tail<3>();
    samples.push_back(v);
  }
  return samples;
}

/// Two tangents describe the same element at theta = pi, where omega and -omega coincide.
template <typename Group>
void expectSameElement(const Group& a, const Group& b, double tolerance) {
  EXPECT_LT((a.matrix() - b.matrix()).norm(), tolerance) << a.matrix() << "\nvs\n" << b.matrix();
}

TEST(SE3, ExpMatchesMatrixExponentialOfHat) {
  for (const SE3::Tangent& xi : se3Samples()) {
    const Eigen::Matrix4d expected = SE3::hat(xi).exp();
    EXPECT_LT((SE3::exp(xi).matrix() - expected).norm(), 1e-12 * expected.norm()) << xi.transpose();
  }
}

TEST(Sim3, ExpMatchesMatrixExponentialOfHat) {
  for (const Sim3::Tangent& xi : sim3Samples()) {
    const Eigen::Matrix4d expected = Sim3::hat(xi).exp();
    const double tolerance = 1e-12 * std::max(1.0, expected.norm());
    EXPECT_LT((Sim3::exp(xi).matrix() - expected).norm(), tolerance) << xi.transpose();
  }
}

TEST(SE3, LogInvertsExp) {
  for (const SE3::Tangent& xi : se3Samples()) {
    const SE3 T = SE3::exp(xi);
    expectSameElement(SE3::exp(T.log()), T, 1e-12);
    if (xi.head<3>().norm() < M_PI - 1e-6) {
      EXPECT_LT((T.log() - xi).norm(), 1e-9) << xi.transpose();
    }
  }
}

TEST(Sim3, LogInvertsExp) {
  for (const Sim3::Tangent& xi : sim3Samples()) {
    const Sim3 S = Sim3::exp(xi);
    const double scale = std::max(1.0, S.matrix().norm());
    expectSameElement(Sim3::exp(S.log()), S, 1e-12 * scale);
    if (xi.head<3>().norm() < M_PI - 1e-6) {
      EXPECT_LT((S.log() - xi).norm(), 1e-9 * std::max(1.0, xi.norm())) << xi.transpose();
    }
  }
}

TEST(SE3, HatVeeRoundTrip) {
  for (const SE3::Tangent& xi : se3Samples())
    EXPECT_EQ(SE3::vee(SE3::hat(xi)), xi);
}

TEST(Sim3, HatVeeRoundTrip) {
  for (const Sim3::Tangent& xi : sim3Samples()) {
    EXPECT_LT((Sim3::vee(Sim3::hat(xi)) - xi).norm(), 1e-15 * std::max(1.0, xi.norm()));
  }
}

TEST(Sim3, GroupAxioms) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uniform(-2.0, 2.0);
  auto random_sim3 = [&] {
    Sim3::Tangent xi;
    for (int i = 0; i < 7; ++i)
      xi[i] = uniform(rng);
    return Sim3::exp(xi);
  };
  for (int trial = 0; trial < 100; ++trial) {
    const Sim3 a = random_sim3(), b = random_sim3(), c = random_sim3();
    const Eigen::Vector3d x(uniform(rng), uniform(rng), uniform(rng));
    expectSameElement((a * b) * c, a * (b * c), 1e-9);
    expectSameElement(a * Sim3::identity(), a, 1e-12);
    expectSameElement(a * a.inverse(), Sim3::identity(), 1e-12);
    expectSameElement(a.inverse() * a, Sim3::identity(), 1e-12);
    EXPECT_LT(((a * b) * x - a * (b * x)).norm(), 1e-9);
    EXPECT_LT((a.matrix() * x.homogeneous() - (a * x).homogeneous()).norm(), 1e-12);
    EXPECT_NEAR((a * b).scale(), a.scale() * b.scale(), 1e-12 * (a * b).scale());
  }
}

TEST(SE3, GroupAxioms) {
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> uniform(-3.0, 3.0);
  for (int trial = 0; trial < 100; ++trial) {
    SE3::Tangent u, v;
    for (int i = 0; i < 6; ++i)
      u[i] = uniform(rng), v[i] = uniform(rng);
    const SE3 a = SE3::exp(u), b = SE3::exp(v);
    const Eigen::Vector3d x(uniform(rng), uniform(rng), uniform(rng));
    expectSameElement(a * a.inverse(), SE3::identity(), 1e-12);
    EXPECT_LT(((a * b) * x - a * (b * x)).norm(), 1e-12);
    EXPECT_LT((a.matrix() * b.matrix() - (a * b).matrix()).norm(), 1e-12);
    EXPECT_LT((a.inverseTranslation() - a.inverse().translation()).norm(), 1e-12);
  }
}

TEST(Sim3, AdjointMovesTangentsThroughTheGroup) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> uniform(-1.5, 1.5);
  for (int trial = 0; trial < 50; ++trial) {
    Sim3::Tangent s_xi, delta;
    for (int i = 0; i < 7; ++i)
      s_xi[i] = uniform(rng), delta[i] = 0.3 * uniform(rng);
    const Sim3 S = Sim3::exp(s_xi);
    expectSameElement(S * Sim3::exp(delta) * S.inverse(), Sim3::exp(S.adjoint() * delta),
                      1e-10 * S.matrix().norm());
  }
}

TEST(SE3, AdjointMovesTangentsThroughTheGroup) {
  std::mt19937 rng(10);
  std::uniform_real_distribution<double> uniform(-2.0, 2.0);
  for (int trial = 0; trial < 50; ++trial) {
    SE3::Tangent t_xi, delta;
    for (int i = 0; i < 6; ++i)
      t_xi[i] = uniform(rng), delta[i] = 0.3 * uniform(rng);
    const SE3 T = SE3::exp(t_xi);
    expectSameElement(T * SE3::exp(delta) * T.inverse(), SE3::exp(T.adjoint() * delta), 1e-10);
  }
}

TEST(Sim3, ConversionsToAndFromSE3) {
  SE3::Tangent v;
  v << 0.3, -0.2, 0.9, 1.0, 2.0, -3.0;
  const SE3 T = SE3::exp(v);
  const Sim3 S(T);
  EXPECT_EQ(S.scale(), 1.0);
  expectSameElement(S.toSE3(), T, 1e-15);
  // A scaled similarity keeps its rotation and its camera centre as a rigid pose.
  const Sim3 scaled = Sim3::fromScale(T.rotation(), T.translation(), 2.7);
  const SE3 rigid = scaled.toSE3();
  EXPECT_LT((rigid.rotationMatrix() - T.rotationMatrix()).norm(), 1e-15);
  EXPECT_LT((rigid.inverseTranslation() - scaled.inverse().translation()).norm(), 1e-12);
  EXPECT_LT((rigid.translation() - T.translation() / 2.7).norm(), 1e-15);
}

/// Numeric derivative of f(exp(delta) X) with respect to delta at 0, central differences.
template <int N, int M, typename F>
Eigen::Matrix<double, M, N> numericJacobian(const F& f) {
  Eigen::Matrix<double, M, N> J;
  const double h = 1e-6;
  for (int i = 0; i < N; ++i) {
    Eigen::Matrix<double, N, 1> d = Eigen::Matrix<double, N, 1>::Zero();
    d[i] = h;
    J.col(i) = (f(d) - f(-d)) / (2 * h);
  }
  return J;
}

TEST(Lie, ActionJacobiansMatchNumericDerivatives) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 20; ++trial) {
    Sim3::Tangent xi;
    xi << randomVector(rng, 1.0), 0.4, randomVector(rng, 2.0);
    const Sim3 S = Sim3::exp(xi);
    const Eigen::Vector3d x = randomVector(rng, 3.0);
    const auto numeric_sim3 = numericJacobian<7, 3>(
        [&](const Sim3::Tangent& d) { return Eigen::Vector3d(Sim3::exp(d) * S * x); });
    EXPECT_LT((Sim3::actionJacobian(S * x) - numeric_sim3).norm(), 1e-6);

    const SE3 T = S.toSE3();
    const auto numeric_se3 = numericJacobian<6, 3>(
        [&](const SE3::Tangent& d) { return Eigen::Vector3d(SE3::exp(d) * T * x); });
    EXPECT_LT((SE3::actionJacobian(T * x) - numeric_se3).norm(), 1e-6);
  }
}

/// The pose-graph residual r = log(exp(delta) S) as Ceres sees it: autodiff through exp, the
/// product and log must equal central differences, on every branch of the series.
TEST(Sim3, AutodiffThroughExpAndLogMatchesNumericDerivatives) {
  using Jet = ceres::Jet<double, 7>;
  std::mt19937 rng(12);
  for (double theta : kAngles) {
    if (theta > M_PI - 1e-2) continue;  // log is not differentiable at theta = pi itself
    for (double sigma : kSigmas) {
      Sim3::Tangent xi;
      xi << randomVector(rng, theta), sigma, randomVector(rng, 1.5);
      const Sim3 S = Sim3::exp(xi);

      Eigen::Matrix<Jet, 7, 1> delta;
      for (int i = 0; i < 7; ++i)
        delta[i] = Jet(0.0, i);
      const Eigen::Matrix<Jet, 7, 1> r = (Sim3T<Jet>::exp(delta) * S.cast<Jet>()).log();
      Eigen::Matrix<double, 7, 7> autodiff;
      for (int i = 0; i < 7; ++i)
        autodiff.row(i) = r[i].v.transpose();

      const auto numeric = numericJacobian<7, 7>(
          [&](const Sim3::Tangent& d) { return Sim3::Tangent((Sim3::exp(d) * S).log()); });
      EXPECT_LT((autodiff - numeric).norm(), 1e-5 * std::max(1.0, numeric.norm()))
          << "theta " << theta << " sigma " << sigma << "\n"
          << autodiff << "\nvs\n"
          << numeric;
    }
  }
}

TEST(SE3, AutodiffThroughExpAndLogMatchesNumericDerivatives) {
  using Jet = ceres::Jet<double, 6>;
  std::mt19937 rng(13);
  for (double theta : kAngles) {
    if (theta > M_PI - 1e-2) continue;
    SE3::Tangent xi;
    xi << randomVector(rng, theta), randomVector(rng, 1.5);
    const SE3 T = SE3::exp(xi);
    Eigen::Matrix<Jet, 6, 1> delta;
    for (int i = 0; i < 6; ++i)
      delta[i] = Jet(0.0, i);
    const Eigen::Matrix<Jet, 6, 1> r = (SE3T<Jet>::exp(delta) * T.cast<Jet>()).log();
    Eigen::Matrix<double, 6, 6> autodiff;
    for (int i = 0; i < 6; ++i)
      autodiff.row(i) = r[i].v.transpose();
    const auto numeric = numericJacobian<6, 6>(
        [&](const SE3::Tangent& d) { return SE3::Tangent((SE3::exp(d) * T).log()); });
    EXPECT_LT((autodiff - numeric).norm(), 1e-5 * std::max(1.0, numeric.norm())) << theta;
  }
}

TEST(SO3, LogIsAccurateNearPi) {
  for (double epsilon : {1e-3, 1e-6, 1e-9, 0.0}) {
    const Eigen::Vector3d axis = Eigen::Vector3d(1, -2, 0.5).normalized();
    const Eigen::Vector3d omega = axis * (M_PI - epsilon);
    const Eigen::Vector3d recovered = logSO3(expSO3(omega));
    // At exactly pi the sign of the axis is arbitrary.
    EXPECT_LT(std::min((recovered - omega).norm(), (recovered + omega).norm()), 1e-12);
  }
}

}  // namespace
}  // namespace scale_drift_slam::geometry
