#pragma once
// The tf frames of the SLAM (REP 103/105, doc/ros.md). The core's SLAM world W is the first
// keyframe's camera optical frame (x right, y down, z forward). Published:
//   map -> odom            the loop corrections (identity until a loop closes)
//   odom -> camera body    the tracked pose in the uncorrected, continuous frame
//   camera body -> optical static, the REP 103 rotation (body: x forward, y left, z up)
// `map` is W rotated into body axes (z up when the first camera looks level) unless map_z_up is
// off, then map = W. A loop correction is a similarity that tf cannot express; the accumulated
// correction C (W_corrected <- W_odom) moves the odom pose of the camera by C^-1 (centre by the
// similarity, rotation by its rotation) and map -> odom is then the rigid transform that makes
// map -> camera exactly the tracker's pose.

#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/geometry/sim3.h"

namespace scale_drift_slam::ros_conversions {

/// T_body_optical: maps optical-frame points into the camera body frame (REP 103:
/// optical z -> body x, optical x -> body -y, optical y -> body -z).
geometry::SE3 bodyFromOptical();
/// T_map_world: the rotation from the SLAM world into `map` (bodyFromOptical() when z up,
/// identity otherwise).
geometry::SE3 mapFromWorld(bool map_z_up);

/// The dynamic transforms of one tracked frame. T_map_body = T_map_odom * T_odom_body exactly.
struct CameraTransforms {
  geometry::SE3 T_map_odom;
  geometry::SE3 T_odom_body;
  geometry::SE3 T_map_body;
};

/// The accumulated loop correction of the tracking node and the transforms it implies. Owned by
/// the tracking node, used on its camera thread.
class OdomFrame {
 public:
  explicit OdomFrame(bool map_z_up) : T_map_world_(ros_conversions::mapFromWorld(map_z_up)) {}

  /// A loop correction of the tracker's map (MapUpdate::S_new_old): C <- S_new_old * C.
  void applyCorrection(const geometry::Sim3& S_new_old) { C_ = S_new_old * C_; }
  /// Back to no correction (tracker reset).
  void reset() { C_ = geometry::Sim3(); }
  /// The transforms for the tracker's pose T_cam_world (SLAM world -> optical camera frame).
  CameraTransforms transforms(const geometry::SE3& T_cam_world) const;

  const geometry::Sim3& correction() const { return C_; }
  const geometry::SE3& mapFromWorld() const { return T_map_world_; }

 private:
  geometry::SE3 T_map_world_;
  geometry::Sim3 C_;  ///< Maps uncorrected (odom) SLAM-world coordinates into corrected ones.
};

}  // namespace scale_drift_slam::ros_conversions
