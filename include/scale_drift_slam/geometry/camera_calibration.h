#pragma once
// The calibration of one camera as plain data, independent of ROS and of any file format. It is
// what a calibration YAML (io/calibration_io.h) or a sensor_msgs/CameraInfo (src/ros) becomes.

#include <string>
#include <vector>

namespace scale_drift_slam::geometry {

/// Lens models. Names follow ROS CameraInfo: plumb_bob (= OpenCV radial-tangential) and
/// equidistant (= OpenCV fisheye, Kannala-Brandt).
enum class DistortionModel {
  kRadialTangential,  ///< k1 k2 p1 p2 [k3]; none at all means a linear pinhole.
  kEquidistant,       ///< k1 k2 k3 k4.
};

/// Parses the model names used by ROS, OpenCV, Kalibr and EuRoC ("plumb_bob", "radtan",
/// "radial-tangential", "pinhole", "none", "equidistant", "fisheye", "kannala_brandt").
/// Throws std::invalid_argument naming the accepted spellings.
DistortionModel parseDistortionModel(const std::string& name);
/// "plumb_bob" or "equidistant" (the ROS CameraInfo names).
std::string distortionModelName(DistortionModel model);

struct CameraCalibration {
  DistortionModel model = DistortionModel::kRadialTangential;
  double fx = 0.0;
  double fy = 0.0;
  double cx = 0.0;
  double cy = 0.0;
  int width = 0;
  int height = 0;
  std::vector<double> distortion;  ///< Coefficients in the order of the model (above).
  /// A rolling shutter's readout time (s): row y is exposed at the frame's time plus
  /// readout x ((y + 0.5) / height - 0.5), so the stamp is the middle row's. 0: a global
  /// shutter. The tracker then measures each row from the pose at its own time
  /// (geometry/rolling_shutter_camera.h).
  double rolling_shutter_readout_s = 0.0;

  /// Throws std::invalid_argument with the reason when the calibration cannot be used: a
  /// non-positive or non-finite focal length or one above 100x the image size, a principal
  /// point far off the image (more than one image size outside it), a non-positive image size
  /// or one above 100000, the wrong number of coefficients or a non-finite coefficient or one
  /// above 1000 in magnitude, a rolling-shutter readout time that is negative, not finite or
  /// above 1 s.
  void validate() const;
  /// One line for logs: "plumb_bob 640x480 fx=.. fy=.. cx=.. cy=.. d=[..]".
  std::string describe() const;
  /// (fx + fy) / 2: pixels per unit of normalised image coordinates, for error thresholds and
  /// robust kernels given in pixels.
  double meanFocalLength() const { return 0.5 * (fx + fy); }
  /// The same camera up to the jitter of a calibration republished with rounding or refined
  /// online: same model and size, every pixel of the image mapped within `tolerance_px` (focal
  /// lengths and principal point within tolerance_px over the half image; coefficients within
  /// tolerance_px / half diagonal in pixels). The rolling-shutter readout is not compared: it
  /// times the rows and leaves the geometry, and a map made with one camera serves the other.
  bool sameCameraAs(const CameraCalibration& other, double tolerance_px = 0.5) const;
};

}  // namespace scale_drift_slam::geometry
