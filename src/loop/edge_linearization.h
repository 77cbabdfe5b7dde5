#pragma once
// Internal to the loop module: the linearisation of one pose-graph edge (used by the analytic
// Ceres cost in pose_graph_residuals.cpp; kept apart so that another solver can reuse it).
//   r = log(M S_to S_from^-1),  dr/dd_to = Jl(r)^-1 Adj(M),  dr/dd_from = -Jl(r)^-1 Adj(E),
// E = M S_to S_from^-1, left-multiplied updates (pose_graph_residuals.h derives them).

#include <algorithm>
#include <stdexcept>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "scale_drift_slam/geometry/lie_jacobians.h"
#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/geometry/sim3.h"

namespace scale_drift_slam::loop {

/// What the templates below need to know about a group beyond its own interface.
template <typename Group>
struct GroupTraits;
template <>
struct GroupTraits<geometry::Sim3> {
  static constexpr int kTangent = 7;
  static constexpr int kAmbient = 8;
  template <typename T>
  using Templated = geometry::Sim3T<T>;
  static Eigen::Matrix<double, 7, 7> inverseLeftJacobian(const geometry::Sim3::Tangent& r) {
    return geometry::inverseLeftJacobianSim3(r);
  }
  /// d t' / d delta of t' = exp(delta) applied to the translation: [-[t]x, t, I]; the scale
  /// sigma' = sigma + delta_sigma.
  static void translationAndScaleJacobian(const geometry::Sim3& S, double* J) {
    Eigen::Map<Eigen::Matrix<double, 8, 7, Eigen::RowMajor>> P(J);
    P.block<3, 3>(4, 0) = -geometry::hatSO3<double>(S.translation());
    P.block<3, 1>(4, 3) = S.translation();
    P.block<3, 3>(4, 4).setIdentity();
    P(7, 3) = 1.0;
  }
};
template <>
struct GroupTraits<geometry::SE3> {
  static constexpr int kTangent = 6;
  static constexpr int kAmbient = 7;
  template <typename T>
  using Templated = geometry::SE3T<T>;
  static Eigen::Matrix<double, 6, 6> inverseLeftJacobian(const geometry::SE3::Tangent& r) {
    return geometry::inverseLeftJacobianSE3(r);
  }
  static void translationAndScaleJacobian(const geometry::SE3& T, double* J) {
    Eigen::Map<Eigen::Matrix<double, 7, 6, Eigen::RowMajor>> P(J);
    P.block<3, 3>(4, 0) = -geometry::hatSO3<double>(T.translation());
    P.block<3, 3>(4, 3).setIdentity();
  }
};

/// L^T of Lambda = L L^T; throws unless Lambda is finite, symmetric and positive definite.
template <int N>
Eigen::Matrix<double, N, N> sqrtInformation(const Eigen::Matrix<double, N, N>& information) {
  if (!information.allFinite()) {
    throw std::invalid_argument("information matrix is not finite");
  }
  const double asymmetry = (information - information.transpose()).cwiseAbs().maxCoeff();
  if (asymmetry > 1e-9 * std::max(1.0, information.cwiseAbs().maxCoeff())) {
    throw std::invalid_argument("information matrix is not symmetric");
  }
  const Eigen::LLT<Eigen::Matrix<double, N, N>> llt(information);
  if (llt.info() != Eigen::Success || !(llt.matrixL().toDenseMatrix().diagonal().minCoeff() > 0)) {
    throw std::invalid_argument("information matrix is not positive definite");
  }
  return llt.matrixU();
}

/// One edge with its precomputed constants: the measurement M, Adj(M) and L^T (Lambda = L L^T).
template <typename Group>
struct EdgeModel {
  static constexpr int kTangent = GroupTraits<Group>::kTangent;
  using Matrix = Eigen::Matrix<double, kTangent, kTangent>;
  using Tangent = typename Group::Tangent;

  EdgeModel(const Group& measurement_in, const Matrix& sqrt_information_in)
      : measurement(measurement_in),
        measurement_adjoint(measurement_in.adjoint()),
        sqrt_information(sqrt_information_in),
        identity_information(sqrt_information_in.isIdentity(0.0)) {}

  /// The weighted residual L^T r and, where asked for, its Jacobians w.r.t. the left-multiplied
  /// tangents of S_from and S_to.
  void linearize(const Group& S_from, const Group& S_to, Tangent* residual, Matrix* J_from,
                 Matrix* J_to) const {
    const Group E = measurement * S_to * S_from.inverse();
    const Tangent r = E.log();
    *residual = identity_information ? r : (sqrt_information * r).eval();
    if (J_from == nullptr && J_to == nullptr) {
      return;
    }
    // Jl^-1, Adj(E) and Adj(M) share the block structure of geometry::multiplyTangentMaps.
    const Matrix jl_inverse = GroupTraits<Group>::inverseLeftJacobian(r);
    if (J_from != nullptr) {
      *J_from = -geometry::multiplyTangentMaps(jl_inverse, E.adjoint());
    }
    if (J_to != nullptr) {
      *J_to = geometry::multiplyTangentMaps(jl_inverse, measurement_adjoint);
    }
    if (!identity_information) {
      if (J_from != nullptr) {
        *J_from = (sqrt_information * *J_from).eval();
      }
      if (J_to != nullptr) {
        *J_to = (sqrt_information * *J_to).eval();
      }
    }
  }

  Group measurement;
  Matrix measurement_adjoint;
  Matrix sqrt_information;
  bool identity_information;
};

}  // namespace scale_drift_slam::loop
