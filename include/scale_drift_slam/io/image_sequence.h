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
  /// Why `image` is empty, when the reader knows (a truncated message, a size mismatch).
  std::string problem;
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
  /// What is odd about the sequence but was recovered (stamps out of order, duplicated, all
  /// equal), one line each, for the log.
  virtual std::vector<std::string> warnings() const { return {}; }
};

/// The frames a dataset's list file names, sorted by stamp, and what was odd about it.
struct FrameList {
  std::vector<std::pair<double, std::string>> frames;  ///< (seconds, image path)
  std::vector<std::string> warnings;
};

enum class ListFormat {
  kTum,         ///< rgb.txt: "<seconds> <file>" lines, '#' comments.
  kEuroc,       ///< data.csv: "<nanoseconds>,<file>" lines, '#' comments.
  kKittiTimes,  ///< times.txt: "<seconds>" lines; line i is the image "%06d.png" of number i.
};

/// Parses a list file's text; image paths are relative to `image_dir`. A malformed line or a
/// non-finite stamp (nan, inf) is an error naming the line. Stamps going back in time are
/// sorted (stable), frames with a stamp equal to an earlier one are dropped (the first in the
/// file is kept); both are reported in `warnings` with counts and the first line, as are stamps
/// that are all equal. Throws std::runtime_error naming `origin`, also for an empty list.
FrameList parseFrameList(const std::string& text, ListFormat format, const std::string& origin,
                         const std::string& image_dir);

/// A list of (timestamp, image path) read from disk one by one; the common case of all layouts.
class FileImageSequence : public ImageSequence {
 public:
  FileImageSequence(std::vector<std::pair<double, std::string>> frames,
                    std::optional<geometry::CameraCalibration> calibration, std::string kind,
                    std::vector<std::string> warnings = {});
  std::optional<SequenceFrame> next() override;
  std::size_t size() const override { return frames_.size(); }
  std::optional<geometry::CameraCalibration> calibration() const override { return calibration_; }
  std::string describe() const override;
  std::vector<std::string> warnings() const override { return warnings_; }

 private:
  std::vector<std::pair<double, std::string>> frames_;
  std::vector<std::string> warnings_;
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
