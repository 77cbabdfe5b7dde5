#include "scale_drift_slam/geometry/lie_jacobians.h"

#include <array>
#include <cmath>

#include <Eigen/LU>

namespace scale_drift_slam::geometry {
namespace {

constexpr int kQuadratureNodes = 16;

struct QuadratureRule {
  std::array<double, kQuadratureNodes> nodes;    ///< In (0, 1).
  std::array<double, kQuadratureNodes> weights;  ///< Summing to 1.
};

/// Gauss-Legendre nodes and weights on [0, 1]: the roots of the Legendre polynomial P_n by
/// Newton's method from the Chebyshev guess, weights 2 / ((1 - x^2) P_n'(x)^2), mapped from
/// [-1, 1]. Computed once (thread-safe static initialisation).
const QuadratureRule& gaussLegendre() {
  static const QuadratureRule rule = [] {
    QuadratureRule r{};
    const int n = kQuadratureNodes;
    for (int i = 0; i < n; ++i) {
      double x = std::cos(M_PI * (i + 0.75) / (n + 0.5));
      double derivative = 1.0;
      for (int newton = 0; newton < 100; ++newton) {
        double p_prev = 1.0, p = x;  // P_0, P_1
        for (int k = 2; k <= n; ++k) {
          const double p_next = ((2.0 * k - 1.0) * x * p - (k - 1.0) * p_prev) / k;
          p_prev = p;
          p = p_next;
        }
        derivative = n * (x * p - p_prev) / (x * x - 1.0);
        const double step = p / derivative;
        x -= step;
        if (std::abs(step) < 1e-16) {
          break;
        }
      }
      r.nodes[i] = 0.5 * (1.0 - x);
      r.weights[i] = 1.0 / ((1.0 - x * x) * derivative * derivative);  // 2/(...) halved
    }
    return r;
  }();
  return rule;
}

/// theta^2 + sigma^2: the squared modulus of the largest eigenvalue of ad(xi), which sets the
/// convergence of the series in ad(xi) (upsilon only enters linearly, off the block diagonal).
double spectralRadiusSq(const SE3::Tangent& xi) {
  return xi.head<3>().squaredNorm();
}
double spectralRadiusSq(const Sim3::Tangent& xi) {
  return xi.head<3>().squaredNorm() + xi[3] * xi[3];
}

Eigen::Matrix<double, 6, 6> adOf(const SE3::Tangent& xi) {
  return adSE3(xi);
}
Eigen::Matrix<double, 7, 7> adOf(const Sim3::Tangent& xi) {
  return adSim3(xi);
}

/// Jl = sum_{n=0}^{12} ad^n / (n+1)! for theta^2 + sigma^2 < 0.25 (next term below 1e-13),
/// otherwise integral_0^1 Adj(exp(t xi)) dt by quadrature.
template <typename Group>
Eigen::Matrix<double, Group::Tangent::RowsAtCompileTime, Group::Tangent::RowsAtCompileTime>
leftJacobian(const typename Group::Tangent& xi) {
  constexpr int kDim = Group::Tangent::RowsAtCompileTime;
  using Matrix = Eigen::Matrix<double, kDim, kDim>;
  if (spectralRadiusSq(xi) < 0.25) {
    const Matrix ad = adOf(xi);
    // Horner: I + ad/2! + ad^2/3! + ... = I + ad (1/2 + ad (1/6 + ad (...))).
    Matrix sum = Matrix::Identity() / 479001600.0 / 13.0;  // 1/13!
    double factorial = 479001600.0;                        // 12!
    for (int n = 12; n >= 1; --n) {                        // sum = I/n! + ad sum
      sum = Matrix::Identity() / factorial + multiplyTangentMaps(ad, sum);
      factorial /= n;
    }
    return sum;
  }
  const QuadratureRule& rule = gaussLegendre();
  Matrix sum = Matrix::Zero();
  for (int i = 0; i < kQuadratureNodes; ++i) {
    sum += rule.weights[i] * Group::exp(rule.nodes[i] * xi).adjoint();
  }
  return sum;
}

/// Jl^-1 = x / (e^x - 1) at x = ad(xi) = I - ad/2 + A (1/12 + A (-1/720 + A (1/30240 +
/// A (-1/1209600 + A (1/47900160 - 691 A / 1307674368000))))), A = ad^2 (Bernoulli numbers up to
/// B_12). Below theta^2 + sigma^2 = 1e-4 the terms from ad^6 on are below 1e-14 relative and
/// dropped.
template <typename Group>
Eigen::Matrix<double, Group::Tangent::RowsAtCompileTime, Group::Tangent::RowsAtCompileTime>
inverseLeftJacobian(const typename Group::Tangent& xi) {
  constexpr int kDim = Group::Tangent::RowsAtCompileTime;
  using Matrix = Eigen::Matrix<double, kDim, kDim>;
  const double radius_sq = spectralRadiusSq(xi);
  if (radius_sq >= 0.25) {
    return leftJacobian<Group>(xi).inverse();
  }
  const Matrix ad = adOf(xi);
  const Matrix A = multiplyTangentMaps(ad, ad);
  const Matrix I = Matrix::Identity();
  Matrix tail;
  if (radius_sq < 1e-4) {
    tail = I / 12.0 - A / 720.0;
  } else {
    tail = I / 47900160.0 - A * (691.0 / 1307674368000.0);
    tail = I / -1209600.0 + multiplyTangentMaps(A, tail);
    tail = I / 30240.0 + multiplyTangentMaps(A, tail);
    tail = I / -720.0 + multiplyTangentMaps(A, tail);
    tail = I / 12.0 + multiplyTangentMaps(A, tail);
  }
  return I - 0.5 * ad + multiplyTangentMaps(A, tail);
}

}  // namespace

Matrix6d adSE3(const SE3::Tangent& xi) {
  const Mat3<double> W = hatSO3<double>(xi.head<3>());
  Matrix6d ad = Matrix6d::Zero();
  ad.topLeftCorner<3, 3>() = W;
  ad.bottomLeftCorner<3, 3>() = hatSO3<double>(xi.tail<3>());
  ad.bottomRightCorner<3, 3>() = W;
  return ad;
}

Matrix7d adSim3(const Sim3::Tangent& xi) {
  const Mat3<double> W = hatSO3<double>(xi.head<3>());
  Matrix7d ad = Matrix7d::Zero();
  ad.block<3, 3>(0, 0) = W;
  ad.block<3, 3>(4, 0) = hatSO3<double>(xi.tail<3>());
  ad.block<3, 1>(4, 3) = -xi.tail<3>();
  ad.block<3, 3>(4, 4) = W + Mat3<double>::Identity() * xi[3];
  return ad;
}

Matrix7d multiplyTangentMaps(const Matrix7d& X, const Matrix7d& Y) {
  Matrix7d Z = Matrix7d::Zero();
  const auto YA = Y.block<3, 3>(0, 0);
  const auto XD = X.block<3, 3>(4, 4);
  Z.block<3, 3>(0, 0).noalias() = X.block<3, 3>(0, 0) * YA;
  Z(3, 3) = X(3, 3) * Y(3, 3);
  Z.block<3, 3>(4, 0).noalias() = X.block<3, 3>(4, 0) * YA;
  Z.block<3, 3>(4, 0).noalias() += XD * Y.block<3, 3>(4, 0);
  Z.block<3, 1>(4, 3).noalias() = X.block<3, 1>(4, 3) * Y(3, 3);
  Z.block<3, 1>(4, 3).noalias() += XD * Y.block<3, 1>(4, 3);
  Z.block<3, 3>(4, 4).noalias() = XD * Y.block<3, 3>(4, 4);
  return Z;
}

Matrix6d multiplyTangentMaps(const Matrix6d& X, const Matrix6d& Y) {
  Matrix6d Z = Matrix6d::Zero();
  const auto YA = Y.block<3, 3>(0, 0);
  const auto XD = X.block<3, 3>(3, 3);
  Z.block<3, 3>(0, 0).noalias() = X.block<3, 3>(0, 0) * YA;
  Z.block<3, 3>(3, 0).noalias() = X.block<3, 3>(3, 0) * YA;
  Z.block<3, 3>(3, 0).noalias() += XD * Y.block<3, 3>(3, 0);
  Z.block<3, 3>(3, 3).noalias() = XD * Y.block<3, 3>(3, 3);
  return Z;
}

Matrix6d leftJacobianSE3(const SE3::Tangent& xi) {
  return leftJacobian<SE3>(xi);
}
Matrix7d leftJacobianSim3(const Sim3::Tangent& xi) {
  return leftJacobian<Sim3>(xi);
}
Matrix6d inverseLeftJacobianSE3(const SE3::Tangent& xi) {
  return inverseLeftJacobian<SE3>(xi);
}
Matrix7d inverseLeftJacobianSim3(const Sim3::Tangent& xi) {
  return inverseLeftJacobian<Sim3>(xi);
}

}  // namespace scale_drift_slam::geometry
