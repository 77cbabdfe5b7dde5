// Trajectory evaluation against hand-made trajectories with a known error, scale, offset,
// scale drift, rotation drift and timing.

#include <cmath>

#include <gtest/gtest.h>

#include "scale_drift_slam/evaluation/evaluation_report.h"
#include "scale_drift_slam/evaluation/trajectory_evaluation.h"

namespace scale_drift_slam::evaluation {
namespace {

/// A camera walking a circle of radius 10 m (with some height variation), one pose per 0.1 s.
std::vector<io::StampedPose> circle(int n) {
  std::vector<io::StampedPose> poses;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n;
    const Eigen::Vector3d p(10 * std::cos(a), 10 * std::sin(a), 0.5 * std::sin(3 * a));
    const Eigen::Quaterniond q(Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()));
    poses.push_back({100.0 + 0.1 * i, geometry::SE3(q, p)});
  }
  return poses;
}

/// Maps poses by a similarity: positions S p, orientations R_S R.
std::vector<io::StampedPose> transformed(const std::vector<io::StampedPose>& poses,
                                         const geometry::Sim3& S) {
  std::vector<io::StampedPose> out;
  for (const io::StampedPose& p : poses) {
    out.push_back({p.timestamp, geometry::SE3(S.rotation() * p.T_world_cam.rotation(),
                                              S * p.T_world_cam.translation())});
  }
  return out;
}

TEST(TrajectoryEvaluation, RecoversAKnownSimilarityWithZeroError) {
  const auto truth = circle(400);
  geometry::Sim3::Tangent xi;
  xi << 0.3, -0.2, 1.0, std::log(0.4), 5.0, -3.0, 2.0;
  const geometry::Sim3 S_est_truth = geometry::Sim3::exp(xi);
  const auto estimate = transformed(truth, S_est_truth);
  const TrajectoryEvaluation e = evaluateTrajectory(truth, estimate);
  EXPECT_EQ(e.matched_frames, 400u);
  EXPECT_DOUBLE_EQ(e.tracked_fraction, 1.0);
  EXPECT_NEAR(e.S_truth_estimate.scale(), 1.0 / 0.4, 1e-9);
  EXPECT_LT(e.ate.rmse, 1e-9);
  ASSERT_EQ(e.rpe.size(), 4u);
  for (const RelativePoseError& r : e.rpe) {
    EXPECT_LT(r.translation.max, 1e-9);
    EXPECT_LT(r.rotation_deg.max, 1e-5);
  }
  for (const ScaleSegment& s : e.scale_segments)
    EXPECT_NEAR(s.scale, 1.0, 1e-9);
  EXPECT_NEAR(e.truth_path_length, 2 * M_PI * 10, 1.0);

  // SE(3) alignment cannot undo the scale: the error is large.
  EvaluationParams se3;
  se3.alignment = AlignmentMode::kSE3;
  EXPECT_GT(evaluateTrajectory(truth, estimate, se3).ate.rmse, 3.0);
}

TEST(TrajectoryEvaluation, MeasuresAKnownPositionError) {
  const auto truth = circle(400);
  auto estimate = truth;
  const double d = 0.05;  // alternating +-5 cm off the plane of the walk
  for (size_t i = 0; i < estimate.size(); ++i) {
    estimate[i].T_world_cam.translation().z() += (i % 2 ? d : -d);
  }
  for (const AlignmentMode mode : {AlignmentMode::kSim3, AlignmentMode::kSE3}) {
    EvaluationParams params;
    params.alignment = mode;
    const TrajectoryEvaluation e = evaluateTrajectory(truth, estimate, params);
    EXPECT_NEAR(e.ate.rmse, d, 0.002);
    EXPECT_NEAR(e.ate.median, d, 0.002);
    EXPECT_NEAR(e.ate.max, d, 0.003);
  }
}

TEST(TrajectoryEvaluation, MeasuresScaleDriftPerSegment) {
  // The estimate's steps grow linearly along the path: k(s) = 1 + 0.5 s / L.
  const auto truth = circle(1000);
  std::vector<io::StampedPose> estimate = truth;
  double length = 0;
  const double total = 2 * M_PI * 10;
  for (size_t i = 1; i < truth.size(); ++i) {
    const Eigen::Vector3d step =
        truth[i].T_world_cam.translation() - truth[i - 1].T_world_cam.translation();
    const double k = 1.0 + 0.5 * (length + 0.5 * step.norm()) / total;
    estimate[i].T_world_cam.translation() = estimate[i - 1].T_world_cam.translation() + k * step;
    length += step.norm();
  }
  EvaluationParams params;
  params.scale_segments = 5;
  const TrajectoryEvaluation e = evaluateTrajectory(truth, estimate, params);
  ASSERT_EQ(e.scale_segments.size(), 5u);
  // Segment j covers s in [j, j + 1] L / 5; after aligning the first one its scale is
  // k(first middle) / k(middle of j).
  for (size_t j = 0; j < 5; ++j) {
    const double expected = (1.0 + 0.5 * 0.1) / (1.0 + 0.5 * (0.2 * j + 0.1));
    EXPECT_NEAR(e.scale_segments[j].scale, expected, 0.01) << "segment " << j;
  }
  EXPECT_NEAR(e.scale_drift, 1.05 / 1.45, 0.01);
}

TEST(TrajectoryEvaluation, MeasuresTheScaleDriftPer100m) {
  // The estimate's steps grow exponentially along the path, k(s) = exp(c s): after aligning the
  // first segment, segment j's scale is exp(-c (middle_j - middle_0)), a straight line in log.
  const auto truth = circle(1000);
  std::vector<io::StampedPose> estimate = truth;
  const double c = 0.002;  // per metre: -18.1 % per 100 m
  double length = 0;
  for (size_t i = 1; i < truth.size(); ++i) {
    const Eigen::Vector3d step =
        truth[i].T_world_cam.translation() - truth[i - 1].T_world_cam.translation();
    const double k = std::exp(c * (length + 0.5 * step.norm()));
    estimate[i].T_world_cam.translation() = estimate[i - 1].T_world_cam.translation() + k * step;
    length += step.norm();
  }
  const TrajectoryEvaluation e = evaluateTrajectory(truth, estimate);
  EXPECT_NEAR(e.scale_drift_per_100m, 100.0 * (std::exp(-100.0 * c) - 1.0), 0.5);
  EXPECT_NEAR(e.scale_drift_over_path, 100.0 * (std::exp(-c * e.truth_path_length) - 1.0), 0.5);
  // No drift: 0.
  EXPECT_NEAR(evaluateTrajectory(truth, truth).scale_drift_per_100m, 0.0, 1e-6);
}

TEST(TrajectoryEvaluation, DoesNotExtrapolateTheDriftOfAShortPathTo100m) {
  // A 0.6 m path whose scale falls by ~20 % (the estimate's steps grow as exp(c s), as above):
  // extrapolated to 100 m that would be exp(-37) - 1, -100 % to 14 digits, meaningless (and a
  // growing scale would give ~10^18 %). The drift over the path is kept.
  std::vector<io::StampedPose> truth, estimate;
  const double c = 0.37;  // per metre
  double s = 0;
  for (int i = 0; i < 60; ++i, s += 0.01) {
    const geometry::SE3 pose(Eigen::Quaterniond::Identity(), Eigen::Vector3d(s, 0.0, 0.0));
    truth.push_back({0.1 * i, pose});
    const double estimated_s = (std::exp(c * s) - 1.0) / c;  // steps of length exp(c s)
    estimate.push_back({0.1 * i, geometry::SE3(Eigen::Quaterniond::Identity(),
                                               Eigen::Vector3d(estimated_s, 0.0, 0.0))});
  }
  const TrajectoryEvaluation e = evaluateTrajectory(truth, estimate);
  ASSERT_LT(e.truth_path_length, kMinPathForDriftPer100m);
  EXPECT_TRUE(std::isnan(e.scale_drift_per_100m));
  EXPECT_NEAR(e.scale_drift_over_path, 100.0 * (std::exp(-c * e.truth_path_length) - 1.0), 2.0);
  EXPECT_LT(e.scale_drift_over_path, -10.0);
  const std::string text = summaryText(e);
  EXPECT_NE(text.find("not extrapolated to 100 m"), std::string::npos) << text;
  EXPECT_TRUE(toJson(e)["scale_drift_per_100m_percent"].is_null());
}

TEST(TrajectoryEvaluation, MeasuresAKnownRotationDriftInTheRpe) {
  // Straight walk at 1 m/s; the estimate's heading turns at 2 deg/s, its positions are right.
  std::vector<io::StampedPose> truth, estimate;
  const double rate = 2.0 * M_PI / 180.0;
  for (int i = 0; i < 300; ++i) {
    const double t = 0.1 * i;
    const Eigen::Vector3d p(t, 0.0, 0.0);
    truth.push_back({t, geometry::SE3(Eigen::Quaterniond::Identity(), p)});
    estimate.push_back(
        {t, geometry::SE3(Eigen::Quaterniond(Eigen::AngleAxisd(rate * t, Eigen::Vector3d::UnitY())),
                          p)});
  }
  EvaluationParams params;
  params.rpe_distances = {5.0};
  const TrajectoryEvaluation e = evaluateTrajectory(truth, estimate, params);
  ASSERT_EQ(e.rpe.size(), 1u);
  EXPECT_NEAR(e.rpe[0].rotation_deg.median, 2.0 * 5.0, 0.25);  // 5 m take 5 s
  EXPECT_LT(e.ate.rmse, 1e-9);
}

TEST(TrajectoryEvaluation, AssociatesByTimestampWithinTheTolerance) {
  const auto truth = circle(300);
  std::vector<io::StampedPose> estimate;
  for (size_t i = 0; i < truth.size(); i += 3) {
    io::StampedPose p = truth[i];
    p.timestamp += 0.004;  // 4 ms late
    estimate.push_back(p);
  }
  estimate.push_back({500.0, geometry::SE3()});  // no ground truth near this one
  const TrajectoryEvaluation e = evaluateTrajectory(truth, estimate);
  EXPECT_EQ(e.matched_frames, 100u);
  EXPECT_EQ(e.estimate_frames, 101u);
  EXPECT_NEAR(e.tracked_fraction, 1.0 / 3.0, 1e-12);
  EXPECT_LT(e.ate.rmse, 1e-9);

  const auto pairs = associateByTimestamp(truth, estimate, 0.003);  // tighter than the offset
  EXPECT_TRUE(pairs.empty());
}

TEST(TrajectoryEvaluation, RefusesTooFewMatchesAndBadParameters) {
  const auto truth = circle(50);
  std::vector<io::StampedPose> estimate = {truth[0], truth[1]};
  EXPECT_THROW(evaluateTrajectory(truth, estimate), std::runtime_error);
  EvaluationParams params;
  params.rpe_distances = {-1.0};
  EXPECT_THROW(evaluateTrajectory(truth, truth, params), std::invalid_argument);
  params = EvaluationParams();
  params.scale_segments = 0;
  EXPECT_THROW(evaluateTrajectory(truth, truth, params), std::invalid_argument);
  EXPECT_THROW(parseAlignmentMode("affine"), std::invalid_argument);
  const ErrorStatistics s = errorStatistics({3.0, 1.0, 2.0, 4.0});
  EXPECT_DOUBLE_EQ(s.median, 2.5);
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_DOUBLE_EQ(s.max, 4.0);
  EXPECT_NEAR(s.rmse, std::sqrt(30.0 / 4.0), 1e-12);
}

}  // namespace
}  // namespace scale_drift_slam::evaluation
