#include "scale_drift_slam/evaluation/alignment.h"

#include <cmath>
#include <stdexcept>

#include <Eigen/Geometry>

namespace scale_drift_slam::evaluation {
namespace {

Eigen::Matrix4d umeyama(const std::vector<Eigen::Vector3d>& estimate,
                        const std::vector<Eigen::Vector3d>& truth, bool with_scale) {
  if (estimate.size() != truth.size()) {
    throw std::invalid_argument("alignment needs as many estimated as true positions");
  }
  if (estimate.size() < 3) throw std::invalid_argument("alignment needs at least 3 positions");
  Eigen::Matrix3Xd src(3, estimate.size()), dst(3, truth.size());
  for (size_t i = 0; i < estimate.size(); ++i) {
    src.col(static_cast<Eigen::Index>(i)) = estimate[i];
    dst.col(static_cast<Eigen::Index>(i)) = truth[i];
  }
  return Eigen::umeyama(src, dst, with_scale);
}

}  // namespace

geometry::Sim3 alignSim3(const std::vector<Eigen::Vector3d>& estimate,
                         const std::vector<Eigen::Vector3d>& truth) {
  const Eigen::Matrix4d M = umeyama(estimate, truth, true);
  const Eigen::Matrix3d sR = M.topLeftCorner<3, 3>();
  const double scale = std::cbrt(sR.determinant());
  return geometry::Sim3::fromScale(Eigen::Quaterniond(sR / scale), M.topRightCorner<3, 1>(), scale);
}

geometry::SE3 alignSE3(const std::vector<Eigen::Vector3d>& estimate,
                       const std::vector<Eigen::Vector3d>& truth) {
  const Eigen::Matrix4d M = umeyama(estimate, truth, false);
  return geometry::SE3(Eigen::Matrix3d(M.topLeftCorner<3, 3>()), M.topRightCorner<3, 1>());
}

double positionRmse(const std::vector<Eigen::Vector3d>& estimate,
                    const std::vector<Eigen::Vector3d>& truth) {
  if (estimate.size() != truth.size() || estimate.empty()) {
    throw std::invalid_argument("RMSE needs two non-empty lists of equal size");
  }
  double sum = 0.0;
  for (size_t i = 0; i < estimate.size(); ++i)
    sum += (estimate[i] - truth[i]).squaredNorm();
  return std::sqrt(sum / static_cast<double>(estimate.size()));
}

FirstPoseAlignedError firstPoseAlignedError(const std::vector<geometry::SE3>& T_world_cam_estimate,
                                            const std::vector<geometry::SE3>& T_world_cam_truth) {
  if (T_world_cam_estimate.size() != T_world_cam_truth.size() || T_world_cam_truth.empty()) {
    throw std::invalid_argument("the error measure needs two non-empty trajectories of equal size");
  }
  // Rigid move of the estimate that puts its first pose onto the true first pose.
  const geometry::SE3 T_truth_estimate = T_world_cam_truth[0] * T_world_cam_estimate[0].inverse();
  const Eigen::Vector3d origin = T_world_cam_truth[0].translation();
  std::vector<Eigen::Vector3d> estimate, truth;
  double numerator = 0.0, denominator = 0.0;
  for (size_t i = 0; i < T_world_cam_truth.size(); ++i) {
    const Eigen::Vector3d e = (T_truth_estimate * T_world_cam_estimate[i]).translation() - origin;
    const Eigen::Vector3d t = T_world_cam_truth[i].translation() - origin;
    numerator += e.dot(t);
    denominator += e.squaredNorm();
    estimate.push_back(e);
    truth.push_back(t);
  }
  FirstPoseAlignedError result;
  result.scale = denominator > 0.0 ? numerator / denominator : 1.0;
  for (Eigen::Vector3d& e : estimate)
    e *= result.scale;
  result.rmse = positionRmse(estimate, truth);
  return result;
}

}  // namespace scale_drift_slam::evaluation
