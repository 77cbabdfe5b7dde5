#pragma once
// Trajectory files. TUM format: one line per pose, "timestamp tx ty tz qx qy qz qw", the camera
// pose in the world (T_world_cam: camera -> world), '#' comments. EuRoC ground truth csv:
// "timestamp_ns, px, py, pz, qw, qx, qy, qz, ..." (the body pose in the world).

#include <string>
#include <vector>

#include "scale_drift_slam/geometry/se3.h"

namespace scale_drift_slam::io {

struct StampedPose {
  double timestamp = 0.0;     ///< Seconds.
  geometry::SE3 T_world_cam;  ///< Maps camera points into the world.
};

/// Reads a TUM file (or an EuRoC csv, recognised by its commas). Throws std::runtime_error with
/// the file, the line number and the problem for a missing file or a malformed line.
std::vector<StampedPose> loadTrajectory(const std::string& path);
/// Sorts poses by stamp (stable) and drops the later poses of a stamp already present. Returns
/// how many were dropped (stamps repeated); `reordered` (optional) gets how many stamps went
/// back in time before sorting.
std::size_t sortAndDropRepeatedStamps(std::vector<StampedPose>* poses,
                                      std::size_t* reordered = nullptr);
/// Writes a TUM file (full double precision). Throws std::runtime_error when it cannot.
void saveTumTrajectory(const std::string& path, const std::vector<StampedPose>& poses,
                       const std::string& header_comment = "");

}  // namespace scale_drift_slam::io
