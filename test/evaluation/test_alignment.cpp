// Alignment against trajectories with a known offset, rotation and scale.

#include <random>

#include <gtest/gtest.h>

#include "scale_drift_slam/evaluation/alignment.h"

namespace scale_drift_slam::evaluation {
namespace {

std::vector<Eigen::Vector3d> helix(int n) {
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < n; ++i) {
    points.emplace_back(std::cos(0.1 * i) * 5, std::sin(0.1 * i) * 5, 0.05 * i);
  }
  return points;
}

TEST(Alignment, Sim3RecoversAKnownSimilarity) {
  geometry::Sim3::Tangent xi;
  xi << 0.4, -1.1, 0.3, std::log(0.37), 2.0, -7.0, 1.5;
  const geometry::Sim3 S_truth_est = geometry::Sim3::exp(xi);
  const std::vector<Eigen::Vector3d> truth = helix(100);
  std::vector<Eigen::Vector3d> estimate;
  for (const auto& p : truth)
    estimate.push_back(S_truth_est.inverse() * p);
  const geometry::Sim3 S = alignSim3(estimate, truth);
  EXPECT_LT((S.matrix() - S_truth_est.matrix()).norm(), 1e-9);
  std::vector<Eigen::Vector3d> aligned;
  for (const auto& p : estimate)
    aligned.push_back(S * p);
  EXPECT_LT(positionRmse(aligned, truth), 1e-9);
}

TEST(Alignment, Se3KeepsTheScale) {
  const std::vector<Eigen::Vector3d> truth = helix(50);
  std::vector<Eigen::Vector3d> estimate;
  for (const auto& p : truth)
    estimate.push_back(2.0 * p);  // twice too large
  const geometry::SE3 T = alignSE3(estimate, truth);
  std::vector<Eigen::Vector3d> aligned;
  for (const auto& p : estimate)
    aligned.push_back(T * p);
  EXPECT_GT(positionRmse(aligned, truth), 1.0);
  EXPECT_THROW(alignSim3({Eigen::Vector3d::Zero()}, {Eigen::Vector3d::Zero()}),
               std::invalid_argument);
}

TEST(Alignment, FirstPoseAlignedErrorMeasuresOnlyTheShape) {
  // An estimate that is the truth moved, rotated and scaled by 3 has zero error and scale 1/3.
  std::vector<geometry::SE3> truth, estimate;
  geometry::SE3::Tangent offset;
  offset << 0.2, 0.1, -0.3, 4.0, 5.0, 6.0;
  const geometry::SE3 T_est_truth = geometry::SE3::exp(offset);
  for (const auto& p : helix(60)) {
    geometry::SE3::Tangent xi;
    xi << 0.0, 0.0, p.z(), p.x(), p.y(), p.z();
    truth.push_back(geometry::SE3::exp(xi));
    const geometry::SE3 moved = T_est_truth * truth.back();
    estimate.emplace_back(moved.rotation(), moved.translation() * 3.0);
  }
  // Scaling positions about the world origin is a similarity of the whole trajectory.
  const FirstPoseAlignedError error = firstPoseAlignedError(estimate, truth);
  EXPECT_LT(error.rmse, 1e-9);
  EXPECT_NEAR(error.scale, 1.0 / 3.0, 1e-9);
  // A bent estimate does have an error.
  estimate.back().translation() += Eigen::Vector3d(0, 0, 10);
  EXPECT_GT(firstPoseAlignedError(estimate, truth).rmse, 0.1);
}

}  // namespace
}  // namespace scale_drift_slam::evaluation
