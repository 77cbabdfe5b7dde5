#pragma once
// Motion-only bundle adjustment (doc/algorithm.md, "Front-end: tracking one frame", step 4):
// minimise sum rho(|f (z_k - proj(T x_k))|) over one camera pose T with the points held fixed,
// Levenberg-Marquardt and the pseudo-Huber kernel rho.
//
// Two solvers give the same answer: a hand-written LM with the analytic 2x6 Jacobian and
// iteratively reweighted normal equations (the default: ~20 us for 300 points), and Ceres (DENSE_QR
// on the 6 parameters, kept to measure against: its per-problem set-up costs ~10x more,
// doc/benchmarks.md). Pure function of its input; safe to call from any thread.

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "scale_drift_slam/features/bundle_statistics.h"
#include "scale_drift_slam/geometry/se3.h"

namespace scale_drift_slam::features {

enum class MotionOnlySolver { kHandWritten, kCeres };

struct MotionOnlyBundleAdjustmentParams {
  double huber_width_px = 2.0;       ///< b of the pseudo-Huber kernel, in pixels.
  double inlier_threshold_px = 3.0;  ///< Observations with a larger final error are outliers.
  int max_iterations = 10;
  /// Stop when the update's norm (radians and map units) falls below this.
  double min_step_norm = 1e-9;
  /// Stop when the relative cost decrease of an accepted step falls below this.
  double function_tolerance = 1e-8;
  MotionOnlySolver solver = MotionOnlySolver::kHandWritten;
  /// Throws std::invalid_argument naming the first bad value.
  void validate() const;
};

/// A fixed world point and its observation in undistorted normalised coordinates.
struct PoseObservation {
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
  Eigen::Vector2d xy = Eigen::Vector2d::Zero();
};

struct MotionOnlyInput {
  geometry::SE3 T_cam_world_guess;
  std::vector<PoseObservation> observations;
  double focal_length_px = 0.0;
  /// Throws std::invalid_argument for a non-positive focal length or non-finite values.
  void validate() const;
};

struct MotionOnlyResult {
  geometry::SE3 T_cam_world;
  std::vector<bool> inlier;  ///< Per input observation.
  BundleStatistics statistics;
  /// sum w_k J_k^T J_k at the solution (pixel residuals, left-update tangent (omega, upsilon)):
  /// divided by the pixel noise variance it is the inverse covariance of the pose.
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
  /// sum J_k^T J_k over the inliers only, unweighted (pixel residuals, the same tangent): the
  /// information of the pose per unit pixel noise (poseCovariance).
  Eigen::Matrix<double, 6, 6> inlier_information = Eigen::Matrix<double, 6, 6>::Zero();
};

/// The covariance of a solved pose: sigma_px^2 (J^T J)^-1 for the information J^T J of pixel
/// residuals (MotionOnlyResult::inlier_information) and the pixel noise sigma_px (one standard
/// deviation per image coordinate). Its tangent is the left update T_cam_world <- exp(delta)
/// T_cam_world, delta = (omega [rad], upsilon [map units]): a perturbation in the camera
/// (optical) frame. The map's scale is unknown, so the translation part is in map units^2.
/// Empty when the information is singular (fewer than 3 points, or degenerate) or not finite.
std::optional<Eigen::Matrix<double, 6, 6>> poseCovariance(
    const Eigen::Matrix<double, 6, 6>& information, double pixel_sigma_px);

/// Needs at least 3 observations in front of the camera (throws std::invalid_argument otherwise).
MotionOnlyResult solveMotionOnlyBundleAdjustment(const MotionOnlyInput& input,
                                                 const MotionOnlyBundleAdjustmentParams& params);

/// The minimal solver ransacPose runs on each sample: P3P on 3 observations checked on a 4th
/// (OpenCV's AP3P), or EPnP on 5 (about twice the instructions per sample).
enum class PnpSampleSolver { kP3P, kEPnP };

/// How ransacPose searches: OpenCV's solvePnPRansac on the normalised coordinates.
struct PnpRansacParams {
  double threshold_px = 3.0;  ///< Inliers reproject within this (at the input's focal length).
  int iterations = 100;       ///< Samples at most.
  double confidence = 0.99;   ///< Stop once a better sample is this unlikely.
  PnpSampleSolver solver = PnpSampleSolver::kP3P;
};

/// The pose from the observations alone, without a guess: RANSAC over minimal samples. The
/// indices of its inliers go to `inliers`. Nothing when RANSAC finds no pose (fewer than 4
/// observations among them).
std::optional<geometry::SE3> ransacPose(const MotionOnlyInput& input, const PnpRansacParams& ransac,
                                        std::vector<int>* inliers);

/// ransacPose, then the motion-only BA from its pose on its inliers, whose indices go to `kept`
/// (the result's `inlier` flags are over those). Nothing when RANSAC finds no pose or the BA
/// refuses its inliers.
std::optional<MotionOnlyResult> solvePoseWithoutGuess(
    const MotionOnlyInput& input, const PnpRansacParams& ransac,
    const MotionOnlyBundleAdjustmentParams& params, std::vector<int>* kept);

}  // namespace scale_drift_slam::features
