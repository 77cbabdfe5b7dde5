#include "scale_drift_slam/loop/pose_graph_residuals.h"

#include <cmath>
#include <stdexcept>

#include <ceres/autodiff_cost_function.h>
#include <ceres/sized_cost_function.h>
#include <Eigen/LU>

#include "edge_linearization.h"

namespace scale_drift_slam::loop {
namespace {

using geometry::SE3;
using geometry::Sim3;

/// The vertex manifold: Plus(x, delta) = exp(delta) x. kLifted selects PlusJacobian = [I; 0]
/// (for costs that return dr/d delta, see the header); otherwise the true derivative.
template <typename Group, bool kLifted>
class LeftMultiplyManifold final : public ceres::Manifold {
 public:
  static constexpr int kTangent = GroupTraits<Group>::kTangent;
  static constexpr int kAmbient = GroupTraits<Group>::kAmbient;
  using AmbientByTangent = Eigen::Matrix<double, kAmbient, kTangent, Eigen::RowMajor>;

  int AmbientSize() const override { return kAmbient; }
  int TangentSize() const override { return kTangent; }

  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override {
    const typename Group::Tangent d = Eigen::Map<const typename Group::Tangent>(delta);
    (Group::exp(d) * Group::fromData(x)).toData(x_plus_delta);
    return true;
  }

  bool PlusJacobian(const double* x, double* jacobian) const override {
    Eigen::Map<AmbientByTangent> P(jacobian);
    P.setZero();
    if (kLifted) {
      P.template topRows<kTangent>().setIdentity();
      return true;
    }
    // Quaternion part of q' = (1, omega/2) * q, q = (w, v): d v'/d omega = (w I - [v]x) / 2,
    // d w'/d omega = -v^T / 2.
    const Group X = Group::fromData(x);
    const Eigen::Vector3d v = X.rotation().vec();
    const double w = X.rotation().w();
    P.template block<3, 3>(0, 0) =
        0.5 * (w * Eigen::Matrix3d::Identity() - geometry::hatSO3<double>(v));
    P.template block<1, 3>(3, 0) = -0.5 * v.transpose();
    GroupTraits<Group>::translationAndScaleJacobian(X, jacobian);
    return true;
  }

  bool RightMultiplyByPlusJacobian(const double* x, const int num_rows,
                                   const double* ambient_matrix,
                                   double* tangent_matrix) const override {
    if (!kLifted) {
      return ceres::Manifold::RightMultiplyByPlusJacobian(x, num_rows, ambient_matrix,
                                                          tangent_matrix);
    }
    for (int row = 0; row < num_rows; ++row) {
      for (int col = 0; col < kTangent; ++col) {
        tangent_matrix[row * kTangent + col] = ambient_matrix[row * kAmbient + col];
      }
    }
    return true;
  }

  bool Minus(const double* y, const double* x, double* y_minus_x) const override {
    Eigen::Map<typename Group::Tangent> out(y_minus_x);
    out = (Group::fromData(y) * Group::fromData(x).inverse()).log();
    return true;
  }

  bool MinusJacobian(const double* x, double* jacobian) const override {
    Eigen::Map<Eigen::Matrix<double, kTangent, kAmbient, Eigen::RowMajor>> M(jacobian);
    if (kLifted) {
      M.setZero();
      M.template leftCols<kTangent>().setIdentity();
      return true;
    }
    // The left inverse of PlusJacobian (its pseudo-inverse): Minus(Plus(x, d), x) = d.
    Eigen::Matrix<double, kAmbient, kTangent, Eigen::RowMajor> P;
    PlusJacobian(x, P.data());
    M = (P.transpose() * P).inverse() * P.transpose();
    return true;
  }
};

/// Edge cost with closed-form Jacobians w.r.t. the left-multiplied tangent (lifted, see header).
template <typename Group>
class AnalyticEdgeCost final
    : public ceres::SizedCostFunction<GroupTraits<Group>::kTangent, GroupTraits<Group>::kAmbient,
                                      GroupTraits<Group>::kAmbient> {
 public:
  static constexpr int kTangent = GroupTraits<Group>::kTangent;
  static constexpr int kAmbient = GroupTraits<Group>::kAmbient;
  using Matrix = Eigen::Matrix<double, kTangent, kTangent>;

  AnalyticEdgeCost(const Group& measurement, const Matrix& sqrt_information)
      : model_(measurement, sqrt_information) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    typename Group::Tangent r;
    Matrix J[2];
    const bool want[2] = {jacobians != nullptr && jacobians[0] != nullptr,
                          jacobians != nullptr && jacobians[1] != nullptr};
    model_.linearize(Group::fromData(parameters[0]), Group::fromData(parameters[1]), &r,
                     want[0] ? &J[0] : nullptr, want[1] ? &J[1] : nullptr);
    Eigen::Map<typename Group::Tangent>(residuals, kTangent) = r;
    using Block = Eigen::Matrix<double, kTangent, kAmbient, Eigen::RowMajor>;
    for (int k = 0; k < 2; ++k) {
      if (!want[k]) {
        continue;
      }
      Eigen::Map<Block> block(jacobians[k]);
      block.template leftCols<kTangent>() = J[k];
      block.template rightCols<kAmbient - kTangent>().setZero();
    }
    return true;
  }

 private:
  EdgeModel<Group> model_;
};

/// The same residual for Ceres autodiff (Jets through exp/log of geometry/).
template <typename Group>
struct AutoDiffEdgeResidual {
  static constexpr int kTangent = GroupTraits<Group>::kTangent;
  using Matrix = Eigen::Matrix<double, kTangent, kTangent>;

  template <typename T>
  bool operator()(const T* from, const T* to, T* residual) const {
    using TGroup = typename GroupTraits<Group>::template Templated<T>;
    const TGroup S_from = TGroup::fromData(from);
    const TGroup S_to = TGroup::fromData(to);
    const Eigen::Matrix<T, kTangent, 1> r =
        (measurement.template cast<T>() * S_to * S_from.inverse()).log();
    Eigen::Map<Eigen::Matrix<T, kTangent, 1>> out(residual);
    out = sqrt_information.template cast<T>() * r;
    return true;
  }

  Group measurement;
  Matrix sqrt_information;
};

template <typename Group>
std::unique_ptr<ceres::CostFunction> makeCost(
    PoseGraphJacobians jacobians, const Group& measurement,
    const Eigen::Matrix<double, GroupTraits<Group>::kTangent, GroupTraits<Group>::kTangent>&
        information) {
  constexpr int kTangent = GroupTraits<Group>::kTangent;
  constexpr int kAmbient = GroupTraits<Group>::kAmbient;
  const auto sqrt_information = sqrtInformation<kTangent>(information);
  if (jacobians == PoseGraphJacobians::kAnalytic) {
    return std::make_unique<AnalyticEdgeCost<Group>>(measurement, sqrt_information);
  }
  return std::make_unique<
      ceres::AutoDiffCostFunction<AutoDiffEdgeResidual<Group>, kTangent, kAmbient, kAmbient>>(
      // The cost function takes ownership of the functor (Ceres 2.1 has no unique_ptr overload).
      std::make_unique<AutoDiffEdgeResidual<Group>>(
          AutoDiffEdgeResidual<Group>{measurement, sqrt_information})
          .release());
}

}  // namespace

Eigen::Matrix<double, 6, 6> se3Information(const Matrix7d& information) {
  const int keep[6] = {0, 1, 2, 4, 5, 6};  // (omega, upsilon) of (omega, sigma, upsilon)
  Eigen::Matrix<double, 6, 6> result;
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) {
      result(r, c) = information(keep[r], keep[c]);
    }
  }
  return result;
}

std::unique_ptr<ceres::CostFunction> makeEdgeCost(PoseGraphMode mode, PoseGraphJacobians jacobians,
                                                  const geometry::Sim3& S_from_to,
                                                  const Matrix7d& information) {
  if (mode == PoseGraphMode::kSim3) {
    return makeCost<Sim3>(jacobians, S_from_to, information);
  }
  return makeCost<SE3>(jacobians, dropScale(S_from_to), se3Information(information));
}

std::unique_ptr<ceres::Manifold> makeVertexManifold(PoseGraphMode mode,
                                                    PoseGraphJacobians jacobians) {
  const bool lifted = jacobians == PoseGraphJacobians::kAnalytic;
  if (mode == PoseGraphMode::kSim3) {
    if (lifted) {
      return std::make_unique<LeftMultiplyManifold<Sim3, true>>();
    }
    return std::make_unique<LeftMultiplyManifold<Sim3, false>>();
  }
  if (lifted) {
    return std::make_unique<LeftMultiplyManifold<SE3, true>>();
  }
  return std::make_unique<LeftMultiplyManifold<SE3, false>>();
}

}  // namespace scale_drift_slam::loop
