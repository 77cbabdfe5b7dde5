#include "scale_drift_slam/ros/robot_frames.h"

#include <Eigen/Geometry>

namespace scale_drift_slam::ros_conversions {
namespace {

/// (omega, upsilon) -> (upsilon, omega): our tangent order to ROS' (translation, rotation).
Matrix6d swapHalves(const Matrix6d& M) {
  Matrix6d P = Matrix6d::Zero();
  P.topRightCorner<3, 3>().setIdentity();
  P.bottomLeftCorner<3, 3>().setIdentity();
  return P * M * P.transpose();
}

}  // namespace

geometry::SE3 fromXyzRpy(double x, double y, double z, double roll, double pitch, double yaw) {
  const Eigen::Quaterniond q = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX());
  return geometry::SE3(q, Eigen::Vector3d(x, y, z));
}

geometry::SE3 mapFromOdom(const geometry::SE3& T_map_base, const geometry::SE3& T_odom_base) {
  return T_map_base * T_odom_base.inverse();
}

Matrix6d attachedCovariance(const Matrix6d& Sigma_cam, const geometry::SE3& T_cam_child) {
  const Matrix6d A = T_cam_child.inverse().adjoint();
  return A * Sigma_cam * A.transpose();
}

Matrix6d rosPoseCovariance(const Matrix6d& Sigma_right, const geometry::SE3& T_parent_child,
                           double translation_scale) {
  const Eigen::Matrix3d R = T_parent_child.rotationMatrix();
  Matrix6d M = Matrix6d::Zero();  // (omega, upsilon) -> (position, rotation) in parent axes
  M.topRightCorner<3, 3>() = translation_scale * R;
  M.bottomLeftCorner<3, 3>() = R;
  Matrix6d covariance = M * Sigma_right * M.transpose();
  return 0.5 * (covariance + covariance.transpose());
}

BodyTwist twistBetween(const geometry::SE3& T_parent_child_prev,
                       const geometry::SE3& T_parent_child, double dt) {
  BodyTwist twist;
  if (!(dt > 0.0)) return twist;
  const geometry::SE3 relative = T_parent_child_prev.inverse() * T_parent_child;
  twist.linear = T_parent_child.rotation().conjugate() *
                 (T_parent_child.translation() - T_parent_child_prev.translation()) / dt;
  twist.angular = relative.log().head<3>() / dt;
  return twist;
}

Matrix6d twistCovariance(const Matrix6d& Sigma_right_prev, const Matrix6d& Sigma_right, double dt) {
  if (!(dt > 0.0)) return Matrix6d::Zero();
  return swapHalves(Sigma_right_prev + Sigma_right) / (dt * dt);
}

}  // namespace scale_drift_slam::ros_conversions
