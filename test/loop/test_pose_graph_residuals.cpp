// The pose-graph edge costs and vertex manifolds: zero residual at the truth, and the Jacobian
// Ceres sees (ambient Jacobian times PlusJacobian) equal to the numeric derivative of the
// residual along the manifold's Plus, for analytic and autodiff costs, both modes, small and
// large residuals, identity and general information.

#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "scale_drift_slam/loop/pose_graph_residuals.h"

namespace scale_drift_slam::loop {
namespace {

using geometry::SE3;
using geometry::Sim3;
using DynamicMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

Sim3 randomSim3(std::mt19937& rng, double rotation, double log_scale, double translation) {
  std::normal_distribution<double> normal;
  Sim3::Tangent xi;
  for (int i = 0; i < 7; ++i) {
    xi[i] = normal(rng);
  }
  xi.head<3>() = xi.head<3>().normalized() * rotation;
  xi[3] = log_scale * normal(rng);
  xi.tail<3>() *= translation;
  return Sim3::exp(xi);
}

Matrix7d randomInformation(std::mt19937& rng) {
  std::normal_distribution<double> normal;
  Matrix7d A;
  for (int i = 0; i < 49; ++i) {
    A(i / 7, i % 7) = normal(rng);
  }
  return A * A.transpose() + Matrix7d::Identity();
}

struct Variant {
  PoseGraphMode mode;
  PoseGraphJacobians jacobians;
};
const std::vector<Variant> kVariants = {{PoseGraphMode::kSim3, PoseGraphJacobians::kAnalytic},
                                        {PoseGraphMode::kSim3, PoseGraphJacobians::kAutoDiff},
                                        {PoseGraphMode::kSE3, PoseGraphJacobians::kAnalytic},
                                        {PoseGraphMode::kSE3, PoseGraphJacobians::kAutoDiff}};

std::vector<double> parameters(PoseGraphMode mode, const Sim3& S) {
  std::vector<double> data(mode == PoseGraphMode::kSim3 ? 8 : 7);
  if (mode == PoseGraphMode::kSim3) {
    S.toData(data.data());
  } else {
    S.toSE3().toData(data.data());
  }
  return data;
}

Eigen::VectorXd evaluate(const ceres::CostFunction& cost, const std::vector<double>& from,
                         const std::vector<double>& to, std::vector<DynamicMatrix>* jacobians) {
  const int residuals = cost.num_residuals();
  Eigen::VectorXd r(residuals);
  const double* blocks[2] = {from.data(), to.data()};
  if (jacobians == nullptr) {
    EXPECT_TRUE(cost.Evaluate(blocks, r.data(), nullptr));
    return r;
  }
  jacobians->assign(2, DynamicMatrix(residuals, from.size()));
  double* jacobian_pointers[2] = {(*jacobians)[0].data(), (*jacobians)[1].data()};
  EXPECT_TRUE(cost.Evaluate(blocks, r.data(), jacobian_pointers));
  return r;
}

TEST(PoseGraphResiduals, ZeroAtTheTruth) {
  std::mt19937 rng(1);
  for (const Variant& setup : kVariants) {
    for (int trial = 0; trial < 10; ++trial) {
      Sim3 S_i = randomSim3(rng, 2.0, 0.5, 3.0);
      Sim3 S_j = randomSim3(rng, 2.0, 0.5, 3.0);
      if (setup.mode == PoseGraphMode::kSE3) {  // SE(3) mode compares rigid poses
        S_i = Sim3(S_i.toSE3());
        S_j = Sim3(S_j.toSE3());
      }
      const auto cost =
          makeEdgeCost(setup.mode, setup.jacobians, S_i * S_j.inverse(), randomInformation(rng));
      const Eigen::VectorXd r =
          evaluate(*cost, parameters(setup.mode, S_i), parameters(setup.mode, S_j), nullptr);
      EXPECT_LT(r.norm(), 1e-10) << toString(setup.mode) << " " << toString(setup.jacobians);
    }
  }
}

/// The local Jacobian Ceres forms, ambient Jacobian * PlusJacobian, against central differences
/// of r(Plus(x, delta)).
void expectJacobiansMatchNumeric(const Variant& setup, const Sim3& S_ij, const Sim3& S_i,
                                 const Sim3& S_j, const Matrix7d& information) {
  const auto cost = makeEdgeCost(setup.mode, setup.jacobians, S_ij, information);
  const auto manifold = makeVertexManifold(setup.mode, setup.jacobians);
  const int tangent = manifold->TangentSize(), ambient = manifold->AmbientSize();
  std::vector<std::vector<double>> x = {parameters(setup.mode, S_i), parameters(setup.mode, S_j)};
  std::vector<DynamicMatrix> ambient_jacobians;
  evaluate(*cost, x[0], x[1], &ambient_jacobians);
  for (int block = 0; block < 2; ++block) {
    DynamicMatrix plus_jacobian(ambient, tangent);
    ASSERT_TRUE(manifold->PlusJacobian(x[block].data(), plus_jacobian.data()));
    const DynamicMatrix analytic = ambient_jacobians[block] * plus_jacobian;
    DynamicMatrix numeric(cost->num_residuals(), tangent);
    const double h = 1e-6;
    for (int c = 0; c < tangent; ++c) {
      Eigen::VectorXd delta = Eigen::VectorXd::Zero(tangent);
      std::vector<Eigen::VectorXd> r(2);
      for (int side = 0; side < 2; ++side) {
        delta[c] = side == 0 ? h : -h;
        std::vector<std::vector<double>> moved = x;
        manifold->Plus(x[block].data(), delta.data(), moved[block].data());
        r[side] = evaluate(*cost, moved[0], moved[1], nullptr);
      }
      numeric.col(c) = (r[0] - r[1]) / (2 * h);
    }
    EXPECT_LT((analytic - numeric).norm(), 1e-6 * std::max(1.0, numeric.norm()))
        << toString(setup.mode) << " " << toString(setup.jacobians) << " block " << block
        << "\nanalytic\n"
        << analytic << "\nnumeric\n"
        << numeric;
  }
}

TEST(PoseGraphResiduals, JacobiansMatchNumericDerivatives) {
  std::mt19937 rng(2);
  // Residual sizes: nearly satisfied (consecutive edges), moderate, and a loop edge that is far
  // off in rotation, scale and translation (the SE(3) loop residual never vanishes).
  const std::vector<std::vector<double>> kResiduals = {
      {1e-5, 1e-5, 1e-4}, {0.05, 0.05, 0.2}, {0.6, 0.4, 2.0}, {2.5, 1.0, 5.0}};
  for (const Variant& setup : kVariants) {
    for (const auto& size : kResiduals) {
      for (bool identity : {true, false}) {
        const Sim3 S_i = randomSim3(rng, 2.0, 0.5, 3.0);
        const Sim3 S_j = randomSim3(rng, 2.0, 0.5, 3.0);
        const Sim3 error = randomSim3(rng, size[0], size[1], size[2]);
        const Sim3 S_ij = error * S_i * S_j.inverse();
        const Matrix7d information = identity ? Matrix7d::Identity() : randomInformation(rng);
        expectJacobiansMatchNumeric(setup, S_ij, S_i, S_j, information);
      }
    }
  }
}

TEST(PoseGraphResiduals, ManifoldPlusMinusAndJacobians) {
  std::mt19937 rng(3);
  for (const Variant& setup : kVariants) {
    const auto manifold = makeVertexManifold(setup.mode, setup.jacobians);
    const int tangent = manifold->TangentSize(), ambient = manifold->AmbientSize();
    const std::vector<double> x = parameters(setup.mode, randomSim3(rng, 1.5, 0.5, 2.0));
    Eigen::VectorXd delta = 0.3 * Eigen::VectorXd::Random(tangent);
    std::vector<double> y(ambient), x0(ambient);
    ASSERT_TRUE(manifold->Plus(x.data(), delta.data(), y.data()));
    Eigen::VectorXd back(tangent);
    ASSERT_TRUE(manifold->Minus(y.data(), x.data(), back.data()));
    EXPECT_LT((back - delta).norm(), 1e-12);
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(tangent);
    ASSERT_TRUE(manifold->Plus(x.data(), zero.data(), x0.data()));
    for (int i = 0; i < ambient; ++i) {
      EXPECT_NEAR(x0[i], x[i], 1e-15);
    }
    DynamicMatrix plus(ambient, tangent), minus(tangent, ambient);
    ASSERT_TRUE(manifold->PlusJacobian(x.data(), plus.data()));
    ASSERT_TRUE(manifold->MinusJacobian(x.data(), minus.data()));
    EXPECT_LT((minus * plus - DynamicMatrix::Identity(tangent, tangent)).norm(), 1e-12);
    if (setup.jacobians == PoseGraphJacobians::kAutoDiff) {  // the true derivative of Plus
      for (int c = 0; c < tangent; ++c) {
        Eigen::VectorXd d = Eigen::VectorXd::Zero(tangent);
        std::vector<double> a(ambient), b(ambient);
        d[c] = 1e-7;
        manifold->Plus(x.data(), d.data(), a.data());
        d[c] = -1e-7;
        manifold->Plus(x.data(), d.data(), b.data());
        for (int r = 0; r < ambient; ++r) {
          EXPECT_NEAR((a[r] - b[r]) / 2e-7, plus(r, c), 1e-7);
        }
      }
    }
  }
}

TEST(PoseGraphResiduals, RejectsBadInformation) {
  Matrix7d asymmetric = Matrix7d::Identity();
  asymmetric(0, 1) = 0.5;
  Matrix7d indefinite = Matrix7d::Identity();
  indefinite(3, 3) = -1.0;
  Matrix7d nan = Matrix7d::Identity();
  nan(2, 2) = std::nan("");
  for (const Matrix7d& information : {asymmetric, indefinite, nan, Matrix7d::Zero().eval()}) {
    EXPECT_THROW(
        makeEdgeCost(PoseGraphMode::kSim3, PoseGraphJacobians::kAnalytic, Sim3(), information),
        std::invalid_argument);
  }
}

}  // namespace
}  // namespace scale_drift_slam::loop
