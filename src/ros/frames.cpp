#include "scale_drift_slam/ros/frames.h"

#include <Eigen/Core>

namespace scale_drift_slam::ros_conversions {

geometry::SE3 bodyFromOptical() {
  Eigen::Matrix3d R_body_optical;
  R_body_optical << 0, 0, 1,  //
      -1, 0, 0,               //
      0, -1, 0;
  return geometry::SE3(R_body_optical, Eigen::Vector3d::Zero());
}

geometry::SE3 mapFromWorld(bool map_z_up) {
  return map_z_up ? bodyFromOptical() : geometry::SE3();
}

CameraTransforms OdomFrame::transforms(const geometry::SE3& T_cam_world) const {
  const geometry::SE3 T_optical_body = bodyFromOptical().inverse();
  const geometry::SE3 T_world_cam = T_cam_world.inverse();
  // In the uncorrected frame: the centre mapped back by C^-1, the rotation by C's rotation.
  const geometry::SE3 T_odomworld_cam(C_.rotation().conjugate() * T_world_cam.rotation(),
                                      C_.inverse() * T_world_cam.translation());
  CameraTransforms t;
  t.T_map_body = T_map_world_ * T_world_cam * T_optical_body;
  t.T_odom_body = T_map_world_ * T_odomworld_cam * T_optical_body;
  t.T_map_odom = t.T_map_body * t.T_odom_body.inverse();
  return t;
}

}  // namespace scale_drift_slam::ros_conversions
