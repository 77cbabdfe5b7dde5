#pragma once
// The math of the tracking node's robot outputs (doc/ros.md, "tf on a robot"), free of ROS:
// map -> odom when the robot's odometry owns odom -> base, the pose covariance of the published
// frame from the motion-only BA's covariance of the camera, and the twist from consecutive poses.
//
// Covariances: the motion-only BA's tangent is the left update T_cam_world <- exp(delta)
// T_cam_world, delta = (omega, upsilon) in the camera (optical) frame; for the camera's pose
// T_world_cam that is the right perturbation T_world_cam exp(-delta), with the same covariance.
// ROS (nav_msgs/Odometry) orders the pose covariance (x, y, z, rot x, rot y, rot z) with the
// position and the small rotation both in the axes of header.frame_id, and the twist covariance
// (vx, vy, vz, wx, wy, wz) in child_frame_id. Rotations in rad, translations in map units (the
// map's scale is unknown: map units are not metres).

#include <Eigen/Core>

#include "scale_drift_slam/geometry/se3.h"

namespace scale_drift_slam::ros_conversions {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

/// A transform from x y z roll pitch yaw (as static_transform_publisher and URDF: R =
/// Rz(yaw) Ry(pitch) Rx(roll)).
geometry::SE3 fromXyzRpy(double x, double y, double z, double roll, double pitch, double yaw);

/// map -> odom that makes map -> odom -> base the SLAM's pose of the base, when odom -> base is
/// the robot's own (at the same stamp): T_map_odom = T_map_base * T_odom_base^-1.
geometry::SE3 mapFromOdom(const geometry::SE3& T_map_base, const geometry::SE3& T_odom_base);

/// The covariance of the right perturbation of a frame rigidly attached to the camera:
/// T_x_child = T_x_cam T_cam_child, so T_x_cam exp(xi) T_cam_child = T_x_child
/// exp(Ad(T_cam_child^-1) xi) and the child's covariance is Ad Sigma Ad^T (both in (omega, upsilon)
/// order).
Matrix6d attachedCovariance(const Matrix6d& Sigma_cam, const geometry::SE3& T_cam_child);

/// A right-perturbation covariance (omega, upsilon) of the pose T_parent_child as the ROS pose
/// covariance (x, y, z, rot x, rot y, rot z) in the parent's axes: to first order the position
/// moves by R v and the rotation by exp(R omega) R, R the child's rotation in the parent.
/// `translation_scale` multiplies the position (the odom frame after a loop correction of scale
/// s is 1/s of the map's size).
Matrix6d rosPoseCovariance(const Matrix6d& Sigma_right, const geometry::SE3& T_parent_child,
                           double translation_scale = 1.0);

/// The twist of a frame in its own axes (nav_msgs/Odometry's twist is in child_frame_id).
struct BodyTwist {
  Eigen::Vector3d linear = Eigen::Vector3d::Zero();   ///< map units / s
  Eigen::Vector3d angular = Eigen::Vector3d::Zero();  ///< rad / s
};

/// From the poses of the child in the parent at two times dt > 0 apart: linear = R^T (p - p_prev)
/// / dt in the newer child's axes, angular = log(R_prev^T R) / dt (the same in both).
BodyTwist twistBetween(const geometry::SE3& T_parent_child_prev,
                       const geometry::SE3& T_parent_child, double dt);

/// The twist covariance (vx vy vz wx wy wz, child axes) from the right-perturbation covariances
/// (omega, upsilon) of the two poses, taken as independent: (Sigma_prev + Sigma) / dt^2, reordered.
Matrix6d twistCovariance(const Matrix6d& Sigma_right_prev, const Matrix6d& Sigma_right, double dt);

}  // namespace scale_drift_slam::ros_conversions
