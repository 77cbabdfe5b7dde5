// Motion-only BA against a known pose: noisy observations with gross outliers, both solvers;
// the pose from the observations alone (ransacPose), without a guess.

#include <random>

#include <gtest/gtest.h>

#include "../mapping/scene.h"
#include "scale_drift_slam/features/motion_only_bundle_adjustment.h"

namespace scale_drift_slam::features {
namespace {

constexpr double kFocal = 400.0;

MotionOnlyInput makeInput(const geometry::SE3& T_true, int num_points, double noise_px,
                          double outlier_fraction, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0), unit(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, noise_px / kFocal);
  MotionOnlyInput input;
  input.focal_length_px = kFocal;
  const geometry::SE3 T_world_cam = T_true.inverse();
  while (static_cast<int>(input.observations.size()) < num_points) {
    const double depth = 2.0 + 8.0 * unit(rng);
    const Eigen::Vector3d p_cam(0.7 * u(rng) * depth, 0.5 * u(rng) * depth, depth);
    PoseObservation o;
    o.p_world = T_world_cam * p_cam;
    o.xy = p_cam.head<2>() / p_cam.z() + Eigen::Vector2d(noise(rng), noise(rng));
    if (unit(rng) < outlier_fraction) o.xy += Eigen::Vector2d(u(rng), u(rng)) * 0.2;
    input.observations.push_back(o);
  }
  input.T_cam_world_guess = testing::perturb(T_true, 0.03, 0.1, rng);
  return input;
}

geometry::SE3 truePose() {
  geometry::SE3::Tangent xi;
  xi << 0.3, -0.2, 0.1, 1.0, -2.0, 0.5;
  return geometry::SE3::exp(xi);
}

TEST(MotionOnlyBundleAdjustment, RecoversAKnownPoseDespiteOutliers) {
  const geometry::SE3 T_true = truePose();
  const MotionOnlyInput input = makeInput(T_true, 300, 1.0, 0.1, 3);
  const MotionOnlyResult result =
      solveMotionOnlyBundleAdjustment(input, MotionOnlyBundleAdjustmentParams());
  const geometry::SE3::Tangent error = (result.T_cam_world * T_true.inverse()).log();
  EXPECT_LT(error.head<3>().norm(), 2e-3);
  EXPECT_LT(error.tail<3>().norm(), 1e-2);
  EXPECT_TRUE(result.statistics.converged);
  EXPECT_LT(result.statistics.final_rmse_px, 1.6);
  // ~10% outliers of up to 80 px: most are flagged.
  EXPECT_GT(result.statistics.num_inliers, 250u);
  EXPECT_LT(result.statistics.num_inliers, 285u);
  // The information matrix is symmetric positive definite.
  EXPECT_GT(result.information.ldlt().vectorD().minCoeff(), 0.0);
}

TEST(MotionOnlyBundleAdjustment, HandWrittenAndCeresAgree) {
  const geometry::SE3 T_true = truePose();
  for (unsigned seed : {1u, 2u, 5u}) {
    const MotionOnlyInput input = makeInput(T_true, 120, 0.8, 0.05, seed);
    MotionOnlyBundleAdjustmentParams params;
    params.max_iterations = 30;
    const MotionOnlyResult hand = solveMotionOnlyBundleAdjustment(input, params);
    params.solver = MotionOnlySolver::kCeres;
    const MotionOnlyResult ceres = solveMotionOnlyBundleAdjustment(input, params);
    const geometry::SE3::Tangent diff = (hand.T_cam_world * ceres.T_cam_world.inverse()).log();
    EXPECT_LT(diff.norm(), 1e-5) << seed;
    EXPECT_NEAR(hand.statistics.final_cost, ceres.statistics.final_cost,
                1e-6 * ceres.statistics.final_cost);
  }
}

TEST(MotionOnlyBundleAdjustment, RejectsBadInput) {
  MotionOnlyInput input = makeInput(truePose(), 2, 1.0, 0.0, 1);
  EXPECT_THROW(solveMotionOnlyBundleAdjustment(input, MotionOnlyBundleAdjustmentParams()),
               std::invalid_argument);
  input = makeInput(truePose(), 10, 1.0, 0.0, 1);
  input.observations[3].xy.x() = std::nan("");
  EXPECT_THROW(solveMotionOnlyBundleAdjustment(input, MotionOnlyBundleAdjustmentParams()),
               std::invalid_argument);
  MotionOnlyBundleAdjustmentParams params;
  params.max_iterations = 0;
  EXPECT_THROW(params.validate(), std::invalid_argument);
}

TEST(RansacPose, FindsAKnownPoseWithoutAGuessDespiteHalfTheObservationsWrong) {
  const geometry::SE3 T_true = truePose();
  const MotionOnlyInput input = makeInput(T_true, 120, 0.5, 0.5, 7);
  // The inliers are the observations within 3 px of the true pose: the clean half and the few
  // outliers displaced by less than that.
  int true_inliers = 0;
  for (const PoseObservation& o : input.observations) {
    const Eigen::Vector3d p = T_true * o.p_world;
    true_inliers += (p.head<2>() / p.z() - o.xy).norm() * kFocal < 3.0;
  }
  for (const PnpSampleSolver solver : {PnpSampleSolver::kP3P, PnpSampleSolver::kEPnP}) {
    std::vector<int> inliers;
    const std::optional<geometry::SE3> T = ransacPose(input, {3.0, 100, 0.99, solver}, &inliers);
    ASSERT_TRUE(T.has_value());
    const geometry::SE3::Tangent error = (*T * T_true.inverse()).log();
    EXPECT_LT(error.head<3>().norm(), 5e-3);
    EXPECT_LT(error.tail<3>().norm(), 3e-2);
    EXPECT_NEAR(static_cast<double>(inliers.size()), true_inliers, 0.05 * true_inliers);
    // Refined on its inliers by the motion-only BA: closer still.
    std::vector<int> kept;
    const std::optional<MotionOnlyResult> refined = solvePoseWithoutGuess(
        input, {3.0, 100, 0.99, solver}, MotionOnlyBundleAdjustmentParams(), &kept);
    ASSERT_TRUE(refined.has_value());
    const geometry::SE3::Tangent refined_error = (refined->T_cam_world * T_true.inverse()).log();
    EXPECT_LT(refined_error.head<3>().norm(), 2e-3);
    EXPECT_LT(refined_error.tail<3>().norm(), 1e-2);
  }
}

TEST(RansacPose, GivesNothingForTooFewOrDegenerateObservations) {
  std::vector<int> inliers;
  MotionOnlyInput input = makeInput(truePose(), 3, 0.5, 0.0, 1);
  EXPECT_FALSE(ransacPose(input, PnpRansacParams(), &inliers).has_value());
  EXPECT_TRUE(inliers.empty());
  input = makeInput(truePose(), 20, 0.5, 0.0, 1);
  for (PoseObservation& o : input.observations) {  // every point the same
    o = input.observations.front();
  }
  EXPECT_FALSE(ransacPose(input, PnpRansacParams(), &inliers).has_value());
}

}  // namespace
}  // namespace scale_drift_slam::features
