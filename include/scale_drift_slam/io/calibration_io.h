#pragma once
// Reading and writing camera calibrations as YAML files. Three layouts are read, so that users can
// point the SLAM at the file they already have:
//   - ours:  width, height, fx, fy, cx, cy, distortion_model, distortion: [..]
//   - ROS camera_calibration_parsers: image_width, image_height, camera_matrix: {data: [9]},
//     distortion_model, distortion_coefficients: {data: [..]}
//   - EuRoC / Kalibr sensor.yaml: resolution: [w, h], intrinsics: [fu, fv, cu, cv],
//     distortion_model, distortion_coefficients: [..]
// Each may add rolling_shutter_readout_s: a rolling shutter's readout time in seconds (first to
// last row; 0 or absent: a global shutter).

#include <string>

#include "scale_drift_slam/geometry/camera_calibration.h"

namespace scale_drift_slam::io {

/// Loads and validates a calibration. Throws std::runtime_error naming the file and the problem
/// (missing file, not YAML, missing key, invalid value).
geometry::CameraCalibration loadCalibrationYaml(const std::string& path);
/// Parses calibration YAML text; `origin` names the source in error messages.
geometry::CameraCalibration parseCalibrationYaml(const std::string& text,
                                                 const std::string& origin = "<string>");
/// Writes our layout. Throws std::runtime_error when the file cannot be written.
void saveCalibrationYaml(const geometry::CameraCalibration& calibration, const std::string& path);

}  // namespace scale_drift_slam::io
