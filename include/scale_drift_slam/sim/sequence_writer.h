#pragma once
// Writes rendered frames as a TUM RGB-D style folder:
//   DIR/rgb/<stamp>.png     the images (mono8 or bgr8)
//   DIR/rgb.txt             "stamp rgb/<stamp>.png" per frame
//   DIR/groundtruth.txt     "stamp tx ty tz qx qy qz qw", the camera pose in the world (T_world_cam)
//   DIR/camera.yaml         the calibration (io/calibration_io.h layout)
// Stamps are written with 9 decimals from the frame's integer nanoseconds, so they are exact.

#include <fstream>
#include <string>
#include <vector>

#include "scale_drift_slam/geometry/camera_calibration.h"
#include "scale_drift_slam/io/trajectory_io.h"
#include "scale_drift_slam/sim/sequence.h"

namespace scale_drift_slam::sim {

/// Streams frames into a folder. Owns the open rgb.txt; groundtruth.txt is written by finish().
class TumSequenceWriter {
 public:
  /// Creates DIR and DIR/rgb and writes camera.yaml. Throws std::runtime_error when the folder
  /// cannot be created or written.
  TumSequenceWriter(const std::string& directory, const geometry::CameraCalibration& calibration,
                    const std::string& description = "");
  /// Writes the image and its rgb.txt line. Throws std::runtime_error when writing fails.
  void add(const RenderedFrame& frame);
  /// Writes groundtruth.txt and closes rgb.txt. Called by the destructor if not called before.
  void finish();
  ~TumSequenceWriter();

  /// "1000.033333333": seconds with 9 decimals, exactly the integer nanoseconds.
  static std::string formatStamp(std::int64_t stamp_ns);

 private:
  std::string directory_;
  std::string description_;
  std::ofstream rgb_list_;
  std::vector<io::StampedPose> ground_truth_;
  bool finished_ = false;
};

}  // namespace scale_drift_slam::sim
