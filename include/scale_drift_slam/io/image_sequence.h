#pragma once
// Image sequences on disk, read one frame at a time (so memory does not grow with the length):
//   - TUM RGB-D layout:   DIR/rgb.txt ("timestamp path" lines, '#' comments), optional
//                         DIR/camera.yaml (what render_sequence writes);
//   - EuRoC MAV layout:   DIR/mav0/cam0/data.csv ("timestamp_ns,filename"), images in
//                         cam0/data/, calibration cam0/sensor.yaml (DIR may also be mav0 itself);
//   - KITTI odometry:     DIR/image_0/NNNNNN.png, DIR/times.txt, DIR/calib.txt (P0 line).
// Bags are read by the ROS layer (src/ros). Used by run_sequence; ROS-free.

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "scale_drift_slam/geometry/camera_calibration.h"

namespace scale_drift_slam::io {

struct SequenceFrame {
  double timestamp = 0.0;  ///< Seconds.
  cv::Mat image;           ///< As stored (8-bit grey or BGR, or 16-bit grey); empty if unreadable.
  std::string source;      ///< File name, for messages.
  /// The pixel encoding when the source states it (bags: "rgb8", "mono16", ...); empty: infer
  /// from the image type (8-bit 1/3/4 channels = mono8/bgr8/bgra8, 16-bit = mono16).
  std::string encoding;
};

/// A sequence of frames, read lazily. Not thread-safe.
class ImageSequence {
 public:
  virtual ~ImageSequence() = default;
  /// The next frame, or nothing at the end. An unreadable image file gives a frame with an
  /// empty image (the SLAM rejects it and goes on) rather than an exception.
  virtual std::optional<SequenceFrame> next() = 0;
  virtual std::size_t size() const = 0;
  /// The calibration stored with the sequence, when it has one.
  virtual std::optional<geometry::CameraCalibration> calibration() const = 0;
  virtual std::string describe() const = 0;
};

/// A list of (timestamp, image path) read from disk one by one; the common case of all layouts.
class FileImageSequence : public ImageSequence {
 public:
  FileImageSequence(std::vector<std::pair<double, std::string>> frames,
                    std::optional<geometry::CameraCalibration> calibration, std::string kind);
  std::optional<SequenceFrame> next() override;
  std::size_t size() const override { return frames_.size(); }
  std::optional<geometry::CameraCalibration> calibration() const override { return calibration_; }
  std::string describe() const override;

 private:
  std::vector<std::pair<double, std::string>> frames_;
  std::optional<geometry::CameraCalibration> calibration_;
  std::string kind_;
  std::size_t index_ = 0;
};

/// Recognises the layout of `path` (TUM, EuRoC, KITTI) and opens it. Throws std::runtime_error
/// naming the folder and what is missing when it is none of them or a list file is malformed.
std::unique_ptr<ImageSequence> openImageFolder(const std::string& path);

/// KITTI calib.txt: the "P0:" projection matrix (12 numbers) as a linear pinhole calibration of
/// the given image size. Throws std::runtime_error naming the file when absent or malformed.
geometry::CameraCalibration loadKittiCalibration(const std::string& path, int width, int height);

}  // namespace scale_drift_slam::io
