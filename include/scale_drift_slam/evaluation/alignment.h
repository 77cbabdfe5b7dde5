#pragma once
// Aligning an estimated trajectory to ground truth before measuring its error. A monocular
// estimate lives in its own frame and scale (7 gauge freedoms), so errors are only meaningful
// after a similarity (or, on request, rigid) alignment.

#include <vector>

#include <Eigen/Core>

#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/geometry/sim3.h"

namespace scale_drift_slam::evaluation {

/// The similarity S minimising sum |truth_i - S estimate_i|^2 (Umeyama 1991, through
/// Eigen::umeyama). Throws std::invalid_argument for fewer than 3 pairs or unequal sizes.
geometry::Sim3 alignSim3(const std::vector<Eigen::Vector3d>& estimate,
                         const std::vector<Eigen::Vector3d>& truth);
/// The same with the scale held at 1.
geometry::SE3 alignSE3(const std::vector<Eigen::Vector3d>& estimate,
                       const std::vector<Eigen::Vector3d>& truth);

/// Root mean square of |truth_i - estimate_i|.
double positionRmse(const std::vector<Eigen::Vector3d>& estimate,
                    const std::vector<Eigen::Vector3d>& truth);

/// The paper's error measure (doc/algorithm.md, "The paper's evidence"): move the estimate
/// rigidly so that its first camera pose equals the true first pose, scale it about the first
/// camera centre by the least-squares factor over all frames, and return the RMSE of the camera
/// positions. Poses are T_world_cam.
struct FirstPoseAlignedError {
  double rmse = 0.0;
  double scale = 1.0;  ///< The least-squares scale that was applied.
};
FirstPoseAlignedError firstPoseAlignedError(const std::vector<geometry::SE3>& T_world_cam_estimate,
                                            const std::vector<geometry::SE3>& T_world_cam_truth);

}  // namespace scale_drift_slam::evaluation
