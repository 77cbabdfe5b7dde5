// The robot outputs' math: map -> odom through the robot's odometry (the camera's pose in map
// is the tracker's), the covariance carried to an attached frame and into ROS' layout against
// numeric Jacobians, the twist of known motions, and the mount's roll/pitch/yaw convention.

#include <gtest/gtest.h>

#include "scale_drift_slam/ros/frames.h"
#include "scale_drift_slam/ros/robot_frames.h"

namespace scale_drift_slam::ros_conversions {
namespace {

geometry::SE3 pose(double a, double b, double c, double x, double y, double z) {
  geometry::SE3::Tangent xi;
  xi << a, b, c, x, y, z;
  return geometry::SE3::exp(xi);
}

double distance(const geometry::SE3& a, const geometry::SE3& b) {
  return (a.matrix() - b.matrix()).norm();
}

Matrix6d someCovariance() {
  Eigen::Matrix<double, 6, 6> A;
  A << 1, 2, 0, 1, 0, 3, 0, 1, 4, 0, 2, 0, 2, 0, 1, 1, 0, 1, 0, 3, 0, 2, 1, 0, 1, 0, 2, 0, 1, 1, 0,
      1, 0, 1, 0, 2;
  return 1e-4 * (A * A.transpose() + Matrix6d::Identity());
}

/// The Jacobian of f (R^6 -> R^6) at 0 by central differences.
template <typename F>
Matrix6d numericJacobian(F f) {
  Matrix6d J;
  const double h = 1e-6;
  for (int k = 0; k < 6; ++k) {
    geometry::SE3::Tangent d = geometry::SE3::Tangent::Zero();
    d(k) = h;
    J.col(k) = (f(d) - f(-d)) / (2 * h);
  }
  return J;
}

TEST(RobotFrames, MapToOdomThroughTheRobotsOdometryGivesTheTrackersCamera) {
  // The robot's odometry drifts from the truth; the SLAM knows the camera in map. Through
  // map -> odom (ours) -> base (the robot's) -> camera (the mount) the camera is the SLAM's.
  const geometry::SE3 T_base_body = fromXyzRpy(0.3, 0.0, 0.8, 0.0, 0.35, 0.0);
  const OdomFrame frames(true);
  for (int i = 0; i < 5; ++i) {
    const geometry::SE3 T_cam_world = pose(0.1 * i, -0.05, 0.02 * i, 0.3 * i, -0.1, 0.5 * i);
    const geometry::SE3 T_odom_base = pose(0.01, 0.02 * i, 0.3 * i, 1.0 + i, 0.2 * i, 0.0);
    const CameraTransforms t = frames.transforms(T_cam_world);
    const geometry::SE3 T_map_base = t.T_map_body * T_base_body.inverse();
    const geometry::SE3 T_map_odom = mapFromOdom(T_map_base, T_odom_base);
    const geometry::SE3 T_map_optical = T_map_odom * T_odom_base * T_base_body * bodyFromOptical();
    const geometry::SE3 expected = mapFromWorld(true) * T_cam_world.inverse();
    EXPECT_LT(distance(T_map_optical, expected), 1e-12) << i;
  }
}

TEST(RobotFrames, AttachedCovarianceIsThePerturbationCarriedThroughTheMount) {
  const geometry::SE3 T_world_cam = pose(0.2, -0.4, 0.3, 1.0, 2.0, -0.5);
  const geometry::SE3 T_cam_child = pose(-0.3, 0.1, 0.5, 0.2, -0.7, 0.4);
  const geometry::SE3 T_world_child = T_world_cam * T_cam_child;
  // The child's right perturbation as a function of the camera's: its Jacobian J, then J S J^T.
  const Matrix6d J = numericJacobian([&](const geometry::SE3::Tangent& xi) {
    return geometry::SE3::Tangent(
        (T_world_child.inverse() * T_world_cam * geometry::SE3::exp(xi) * T_cam_child).log());
  });
  const Matrix6d S = someCovariance();
  const Matrix6d expected = J * S * J.transpose();
  EXPECT_LT((attachedCovariance(S, T_cam_child) - expected).norm(), 1e-8 * expected.norm());
}

TEST(RobotFrames, RosPoseCovarianceIsPositionThenRotationInTheParentAxes) {
  const geometry::SE3 T = pose(0.5, -0.2, 1.2, 3.0, -1.0, 0.4);
  const double scale = 0.5;
  // (position, rotation vector in the parent) of T exp(xi), the position scaled.
  const Matrix6d J = numericJacobian([&](const geometry::SE3::Tangent& xi) {
    const geometry::SE3 moved = T * geometry::SE3::exp(xi);
    geometry::SE3::Tangent out;
    out.head<3>() = scale * (moved.translation() - T.translation());
    const Eigen::AngleAxisd rotation(moved.rotation() * T.rotation().conjugate());
    out.tail<3>() = rotation.angle() * rotation.axis();
    return out;
  });
  const Matrix6d S = someCovariance();
  const Matrix6d expected = J * S * J.transpose();
  const Matrix6d covariance = rosPoseCovariance(S, T, scale);
  EXPECT_LT((covariance - expected).norm(), 1e-8 * expected.norm()) << covariance << "\n\n"
                                                                    << expected;
}

TEST(RobotFrames, TwistOfKnownMotions) {
  const geometry::SE3 start = pose(0.1, 0.2, 0.9, 1.0, 2.0, 0.0);
  // Driving 0.5 units forward (child x) while turning 0.2 rad about the child's z, in 0.25 s.
  const geometry::SE3 step(Eigen::Quaterniond(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ())),
                           Eigen::Vector3d(0.5, 0.0, 0.0));
  const BodyTwist twist = twistBetween(start, start * step, 0.25);
  EXPECT_LT((twist.angular - Eigen::Vector3d(0, 0, 0.8)).norm(), 1e-12);
  // In the newer child's axes: the step's translation rotated back by the turn.
  const Eigen::Vector3d expected_linear =
      Eigen::AngleAxisd(-0.2, Eigen::Vector3d::UnitZ()) * Eigen::Vector3d(2.0, 0.0, 0.0);
  EXPECT_LT((twist.linear - expected_linear).norm(), 1e-12);
  // Standing still, and no time: zero.
  EXPECT_LT(twistBetween(start, start, 0.1).linear.norm(), 1e-15);
  EXPECT_LT(twistBetween(start, start * step, 0.0).angular.norm(), 1e-15);
  // Twist covariance: (S1 + S2) / dt^2 reordered to (linear, angular).
  const Matrix6d S = someCovariance();
  const Matrix6d C = twistCovariance(S, 3.0 * S, 0.5);
  EXPECT_LT((C.topLeftCorner<3, 3>() - 16.0 * S.bottomRightCorner<3, 3>()).norm(), 1e-15);
  EXPECT_LT((C.bottomRightCorner<3, 3>() - 16.0 * S.topLeftCorner<3, 3>()).norm(), 1e-15);
  EXPECT_LT((C.topRightCorner<3, 3>() - 16.0 * S.bottomLeftCorner<3, 3>()).norm(), 1e-15);
}

TEST(RobotFrames, MountRollPitchYawAsStaticTransformPublisher) {
  // yaw about z first applied last: R = Rz(yaw) Ry(pitch) Rx(roll).
  const geometry::SE3 yaw = fromXyzRpy(1, 2, 3, 0, 0, M_PI / 2);
  EXPECT_LT((yaw * Eigen::Vector3d::UnitX() - Eigen::Vector3d(1, 3, 3)).norm(), 1e-12);
  const geometry::SE3 pitch = fromXyzRpy(0, 0, 0, 0, M_PI / 2, 0);  // x forward -> down
  EXPECT_LT((pitch * Eigen::Vector3d::UnitX() + Eigen::Vector3d::UnitZ()).norm(), 1e-12);
  const geometry::SE3 both = fromXyzRpy(0, 0, 0, 0.3, 0.0, M_PI / 2);
  // Roll about x first: y -> (0, cos, sin), then yaw 90: (-cos, 0, sin).
  EXPECT_LT(
      (both * Eigen::Vector3d::UnitY() - Eigen::Vector3d(-std::cos(0.3), 0, std::sin(0.3))).norm(),
      1e-12);
}

}  // namespace
}  // namespace scale_drift_slam::ros_conversions
