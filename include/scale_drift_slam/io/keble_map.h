#pragma once
// Reader of the Keble College keyframe map published with the paper's authors' code
// (test/data/keble_college/README.md): sections "Poses" (3x4 T_cam_world blocks), "Scale",
// "LoopId", "Points" (x y z) and "Obs" ("point_id, keyframe_id : u v" in pixels).

#include <string>

#include <Eigen/Core>

#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/map/map.h"

namespace scale_drift_slam::io {

/// The linear camera of the Keble data: u = fx x/z + cx, v = fy y/z + cy with fy < 0 (the image
/// y axis is flipped), 320 x 240 pixels.
struct KebleCamera {
  double fx = 195.0;
  double fy = -195.0;
  double cx = 162.0;
  double cy = 125.0;
  int width = 320;
  int height = 240;
  Eigen::Vector2d focalLength() const { return {fx, fy}; }
};

/// The map before loop closure. The last pose of the file is not a keyframe: it is the current
/// camera measured against the loop keyframe's part of the map when the loop was detected.
struct KebleMap {
  /// Keyframes 0..n-2 (timestamp = index) with T_kf_world, points with ids = their line index,
  /// observations in normalised coordinates x = (u - cx)/fx, y = (v - cy)/fy. Each point's
  /// reference keyframe is the newest keyframe observing it: the authors' demo moves a point
  /// with the last of its observing keyframes in file order, which is the newest.
  map::Map map;
  geometry::SE3 T_current_world;      ///< The last pose of the file (see above).
  map::KeyframeId current_id = 0;     ///< Its index in the file (n - 1).
  map::KeyframeId loop_keyframe = 0;  ///< LoopId: the keyframe the current camera sees again.
  double loop_scale = 1.0;            ///< Scale: the relative scale measured at the loop.
  KebleCamera camera;
};

/// Reads the file. Throws std::runtime_error naming the file, the line and the problem for a
/// missing or unreadable file, a malformed or non-finite number, a rotation that is not one, a
/// missing section, a non-positive scale, a loop id or observation outside the map.
KebleMap loadKebleMap(const std::string& path, const KebleCamera& camera = KebleCamera());

}  // namespace scale_drift_slam::io
