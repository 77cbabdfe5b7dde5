#include "scale_drift_slam/geometry/camera_calibration.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace scale_drift_slam::geometry {

DistortionModel parseDistortionModel(const std::string& name) {
  std::string key = name;
  std::transform(key.begin(), key.end(), key.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (key == "plumb_bob" || key == "radtan" || key == "radial-tangential" ||
      key == "radial_tangential" || key == "pinhole" || key == "none" || key.empty()) {
    return DistortionModel::kRadialTangential;
  }
  if (key == "equidistant" || key == "fisheye" || key == "kannala_brandt" ||
      key == "kannala-brandt") {
    return DistortionModel::kEquidistant;
  }
  throw std::invalid_argument("unknown distortion model '" + name +
                              "' (expected plumb_bob/radtan/pinhole or equidistant/fisheye)");
}

std::string distortionModelName(DistortionModel model) {
  return model == DistortionModel::kEquidistant ? "equidistant" : "plumb_bob";
}

void CameraCalibration::validate() const {
  auto fail = [](const std::string& reason) {
    throw std::invalid_argument("invalid camera calibration: " + reason);
  };
  const double values[] = {fx, fy, cx, cy};
  const char* names[] = {"fx", "fy", "cx", "cy"};
  for (int i = 0; i < 4; ++i) {
    if (!std::isfinite(values[i])) fail(std::string(names[i]) + " is not a finite number");
  }
  if (fx <= 0.0 || fy <= 0.0) {
    std::ostringstream s;
    s << "focal lengths must be positive (fx=" << fx << ", fy=" << fy << ")";
    fail(s.str());
  }
  if (width <= 0 || height <= 0) {
    std::ostringstream s;
    s << "image size must be positive (width=" << width << ", height=" << height << ")";
    fail(s.str());
  }
  if (width > 100000 || height > 100000) {
    std::ostringstream s;
    s << "image size " << width << "x" << height << " is beyond any camera's (at most 100000)";
    fail(s.str());
  }
  // Beyond 100x the image size the field of view is under 0.6 degrees: a unit or typing error.
  if (fx > 100.0 * width || fy > 100.0 * height) {
    std::ostringstream s;
    s << "focal length (fx=" << fx << ", fy=" << fy << ") is more than 100x the " << width << "x"
      << height << " image: not a camera's (pixels expected)";
    fail(s.str());
  }
  if (cx < -width || cx > 2.0 * width || cy < -height || cy > 2.0 * height) {
    std::ostringstream s;
    s << "principal point (" << cx << ", " << cy << ") is far outside the " << width << "x"
      << height << " image";
    fail(s.str());
  }
  if (!std::isfinite(rolling_shutter_readout_s) || rolling_shutter_readout_s < 0.0 ||
      rolling_shutter_readout_s > 1.0) {
    std::ostringstream s;
    s << "rolling_shutter_readout_s (" << rolling_shutter_readout_s
      << ") must be in [0, 1] seconds (0: a global shutter)";
    fail(s.str());
  }
  const size_t n = distortion.size();
  if (model == DistortionModel::kRadialTangential && n != 0 && n != 4 && n != 5) {
    fail("plumb_bob takes 0, 4 or 5 coefficients (k1 k2 p1 p2 [k3]), got " + std::to_string(n));
  }
  if (model == DistortionModel::kEquidistant && n != 4) {
    fail("equidistant takes 4 coefficients (k1 k2 k3 k4), got " + std::to_string(n));
  }
  for (size_t i = 0; i < n; ++i) {
    if (!std::isfinite(distortion[i])) {
      fail("distortion coefficient " + std::to_string(i) + " is not a finite number");
    }
    // Real lenses have coefficients of order 1 (a strong fisheye: tens); beyond, the
    // projection overflows for points inside the image.
    if (std::abs(distortion[i]) > 1000.0) {
      std::ostringstream s;
      s << "distortion coefficient " << i << " (" << distortion[i]
        << ") is beyond any lens's (|coefficient| <= 1000)";
      fail(s.str());
    }
  }
}

std::string CameraCalibration::describe() const {
  std::ostringstream s;
  s << distortionModelName(model) << " " << width << "x" << height << " fx=" << fx << " fy=" << fy
    << " cx=" << cx << " cy=" << cy << " d=[";
  for (size_t i = 0; i < distortion.size(); ++i)
    s << (i ? " " : "") << distortion[i];
  s << "]";
  if (rolling_shutter_readout_s > 0.0) {
    s << " rolling shutter readout " << 1000.0 * rolling_shutter_readout_s << " ms";
  }
  return s.str();
}

bool CameraCalibration::sameCameraAs(const CameraCalibration& other, double tolerance_px) const {
  if (model != other.model || width != other.width || height != other.height ||
      distortion.size() != other.distortion.size()) {
    return false;
  }
  // A change of the focal length by d moves the image's edge by d * (half width / f) pixels.
  const double half = 0.5 * std::max(width, height);
  const double f = std::max(meanFocalLength(), 1e-9);
  if (std::abs(fx - other.fx) * half / f > tolerance_px ||
      std::abs(fy - other.fy) * half / f > tolerance_px || std::abs(cx - other.cx) > tolerance_px ||
      std::abs(cy - other.cy) > tolerance_px) {
    return false;
  }
  const double half_diagonal = 0.5 * std::hypot(width, height);
  for (std::size_t i = 0; i < distortion.size(); ++i) {
    if (!(std::abs(distortion[i] - other.distortion[i]) * half_diagonal <= tolerance_px)) {
      return false;
    }
  }
  return true;
}

}  // namespace scale_drift_slam::geometry
