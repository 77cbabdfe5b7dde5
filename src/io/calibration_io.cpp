#include "scale_drift_slam/io/calibration_io.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <regex>
#include <sstream>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

#include "scale_drift_slam/io/key_suggestion.h"

namespace scale_drift_slam::io {
namespace {

using geometry::CameraCalibration;

[[noreturn]] void fail(const std::string& origin, const std::string& reason) {
  throw std::runtime_error("calibration " + origin + ": " + reason);
}

/// One file layout: the key that identifies it ("" = the fallback) and every key it accepts
/// besides the distortion keys (which all layouts accept).
struct Layout {
  std::string name;
  std::string signature;
  std::vector<std::string> keys;
};

const std::vector<Layout>& layouts() {
  static const std::vector<Layout> all = {
      {"ROS camera_calibration (image_width image_height camera_matrix.data distortion_model "
       "distortion_coefficients.data)",
       "camera_matrix",
       {"image_width", "image_height", "camera_name", "camera_matrix", "distortion_model",
        "rectification_matrix", "projection_matrix"}},
      {"ROS CameraInfo as echoed (width height K distortion_model D)",
       "K",
       {"header", "width", "height", "K", "R", "P", "distortion_model", "binning_x", "binning_y",
        "roi"}},
      {"EuRoC sensor.yaml / Kalibr camchain cam0 (resolution intrinsics camera_model "
       "distortion_model distortion_coefficients or distortion_coeffs)",
       "intrinsics",
       {"sensor_type", "comment", "T_BS", "rate_hz", "resolution", "camera_model", "intrinsics",
        "distortion_model", "T_cam_imu", "T_cn_cnm1", "cam_overlaps", "rostopic",
        "timeshift_cam_imu"}},
      {"ours (width height fx fy cx cy distortion_model, distortion: [..] or D: [..] or "
       "k1 k2 p1 p2 [k3] / k1 k2 k3 k4 keys)",
       "",
       {"width", "height", "fx", "fy", "cx", "cy", "distortion_model", "camera_model"}},
  };
  return all;
}

/// Keys holding the whole list of coefficients, and the OpenCV-style one-key-per-coefficient.
const std::vector<std::string> kDistortionLists = {"distortion", "D", "distortion_coefficients",
                                                   "distortion_coeffs"};
const std::vector<std::string> kDistortionCoefficients = {"k1", "k2", "p1", "p2", "k3", "k4"};
/// A rolling shutter's readout time (s), accepted in every layout (none of them has one).
const std::string kReadoutKey = "rolling_shutter_readout_s";

std::string acceptedLayouts() {
  std::string text;
  for (const Layout& layout : layouts())
    text += (text.empty() ? "" : "; ") + layout.name;
  return "accepted layouts: " + text;
}

/// The key names of a mapping; a key that is not text is an error.
std::vector<std::string> keysOf(const YAML::Node& node, const std::string& origin) {
  std::vector<std::string> keys;
  for (const auto& entry : node) {
    if (!entry.first.IsScalar()) fail(origin, "a key is not a name");
    keys.push_back(entry.first.Scalar());
  }
  return keys;
}

const Layout& layoutOf(const YAML::Node& node, const std::string& origin) {
  for (const Layout& layout : layouts()) {
    if (layout.signature.empty() || node[layout.signature]) {
      std::vector<std::string> accepted = layout.keys;
      accepted.insert(accepted.end(), kDistortionLists.begin(), kDistortionLists.end());
      accepted.insert(accepted.end(), kDistortionCoefficients.begin(),
                      kDistortionCoefficients.end());
      accepted.push_back(kReadoutKey);
      for (const std::string& key : keysOf(node, origin)) {
        if (std::find(accepted.begin(), accepted.end(), key) != accepted.end()) continue;
        fail(origin, unknownKeyMessage("key", key, accepted) + " in a file read as " + layout.name +
                         " (" + acceptedLayouts() + ")");
      }
      return layout;
    }
  }
  fail(origin, acceptedLayouts());  // not reached: the last layout has no signature
}

YAML::Node child(const YAML::Node& node, const std::string& key, const std::string& origin,
                 const std::string& path) {
  if (!node.IsMap()) fail(origin, "'" + path + "' must be a mapping with the key '" + key + "'");
  if (!node[key]) fail(origin, "missing key '" + (path.empty() ? key : path + "." + key) + "'");
  return node[key];
}

template <typename T>
T read(const YAML::Node& node, const std::string& key, const std::string& origin) {
  const YAML::Node value = child(node, key, origin, "");
  try {
    return value.as<T>();
  } catch (const YAML::Exception&) {
    fail(origin, "key '" + key + "' does not hold the expected kind of value");
  }
}

std::vector<double> readSequence(const YAML::Node& node, const std::string& origin,
                                 const std::string& what) {
  if (!node.IsSequence()) fail(origin, what + " must be a list of numbers");
  try {
    return node.as<std::vector<double>>();
  } catch (const YAML::Exception&) {
    fail(origin, what + " must be a list of numbers");
  }
}

/// An image size given as a number: a whole number of pixels in [1, 100000].
int imageSize(double value, const std::string& origin, const std::string& what) {
  if (!(value >= 1.0 && value <= 100000.0) || value != std::floor(value)) {
    std::ostringstream s;
    s << what << " must be a whole number of pixels in [1, 100000], got " << value;
    fail(origin, s.str());
  }
  return static_cast<int>(value);
}

geometry::DistortionModel readModel(const YAML::Node& node, const std::string& origin) {
  std::string name = "plumb_bob";
  if (node["camera_model"]) {  // Kalibr / EuRoC: the projection; ours: may name the lens
    const std::string camera = read<std::string>(node, "camera_model", origin);
    if (camera != "pinhole" && node["distortion_model"]) {
      fail(origin, "camera_model '" + camera + "' is not supported (pinhole only)");
    }
    name = camera;
  }
  if (node["distortion_model"]) name = read<std::string>(node, "distortion_model", origin);
  try {
    return geometry::parseDistortionModel(name);
  } catch (const std::invalid_argument& e) {
    fail(origin, e.what());
  }
}

/// k1 k2 p1 p2 [k3] (plumb_bob) or k1 k2 k3 k4 (equidistant), one key each.
std::vector<double> readCoefficientKeys(const YAML::Node& node, geometry::DistortionModel model,
                                        const std::string& origin) {
  const bool fisheye = model == geometry::DistortionModel::kEquidistant;
  const std::vector<std::string> required = fisheye
                                                ? std::vector<std::string>{"k1", "k2", "k3", "k4"}
                                                : std::vector<std::string>{"k1", "k2", "p1", "p2"};
  const std::string foreign = fisheye ? "p1 p2" : "k4";
  for (const std::string& key : kDistortionCoefficients) {
    if (node[key] && foreign.find(key) != std::string::npos) {
      fail(origin, "key '" + key + "' does not belong to the " +
                       geometry::distortionModelName(model) + " model (" +
                       (fisheye ? "k1 k2 k3 k4" : "k1 k2 p1 p2 [k3]") + ")");
    }
  }
  std::vector<double> coefficients;
  for (const std::string& key : required)
    coefficients.push_back(read<double>(node, key, origin));
  if (!fisheye && node["k3"]) coefficients.push_back(read<double>(node, "k3", origin));
  return coefficients;
}

/// The distortion, from whichever of the accepted keys holds it; given twice is an error.
std::vector<double> readDistortion(const YAML::Node& node, geometry::DistortionModel model,
                                   const std::string& origin) {
  std::vector<std::string> given;
  for (const std::string& key : kDistortionLists) {
    if (node[key]) given.push_back(key);
  }
  bool per_key = false;
  for (const std::string& key : kDistortionCoefficients)
    per_key = per_key || static_cast<bool>(node[key]);
  if (per_key) given.push_back("k1 k2 ...");
  if (given.size() > 1) {
    fail(origin, "the distortion is given twice ('" + given[0] + "' and '" + given[1] + "')");
  }
  if (given.empty()) return {};
  if (per_key) return readCoefficientKeys(node, model, origin);
  YAML::Node list = node[given[0]];
  std::string what = given[0];
  if (list.IsMap()) {  // ROS camera_calibration: {rows, cols, data}
    list = child(list, "data", origin, given[0]);
    what += ".data";
  }
  if (list.IsNull()) return {};
  return readSequence(list, origin, what);
}

/// fx fy cx cy width height of the layout.
void readIntrinsics(const YAML::Node& node, const Layout& layout, const std::string& origin,
                    CameraCalibration* c) {
  if (layout.signature == "camera_matrix" || layout.signature == "K") {
    const bool ros = layout.signature == "camera_matrix";
    const YAML::Node matrix =
        ros ? child(node["camera_matrix"], "data", origin, "camera_matrix") : node["K"];
    const std::string what = ros ? "camera_matrix.data" : "K";
    const std::vector<double> k = readSequence(matrix, origin, what);
    if (k.size() != 9) fail(origin, what + " must hold 9 numbers");
    c->fx = k[0];
    c->cx = k[2];
    c->fy = k[4];
    c->cy = k[5];
    c->width = imageSize(read<double>(node, ros ? "image_width" : "width", origin), origin,
                         ros ? "image_width" : "width");
    c->height = imageSize(read<double>(node, ros ? "image_height" : "height", origin), origin,
                          ros ? "image_height" : "height");
  } else if (layout.signature == "intrinsics") {
    const std::vector<double> k = readSequence(node["intrinsics"], origin, "intrinsics");
    if (k.size() != 4) fail(origin, "intrinsics must be [fu, fv, cu, cv]");
    c->fx = k[0];
    c->fy = k[1];
    c->cx = k[2];
    c->cy = k[3];
    const std::vector<double> size =
        readSequence(child(node, "resolution", origin, ""), origin, "resolution");
    if (size.size() != 2) fail(origin, "resolution must be [width, height]");
    c->width = imageSize(size[0], origin, "resolution[0]");
    c->height = imageSize(size[1], origin, "resolution[1]");
  } else {
    c->fx = read<double>(node, "fx", origin);
    c->fy = read<double>(node, "fy", origin);
    c->cx = read<double>(node, "cx", origin);
    c->cy = read<double>(node, "cy", origin);
    c->width = imageSize(read<double>(node, "width", origin), origin, "width");
    c->height = imageSize(read<double>(node, "height", origin), origin, "height");
  }
}

/// A Kalibr camchain (cam0: {...}, cam1: {...}) is read as its cam0.
YAML::Node cameraNode(const YAML::Node& root, std::string* origin) {
  if (!root["cam0"]) return root;
  static const std::regex camera_key("cam[0-9]+");
  for (const std::string& key : keysOf(root, *origin)) {
    if (!std::regex_match(key, camera_key)) {
      fail(*origin, "key '" + key + "' next to 'cam0' (a Kalibr camchain holds cam0, cam1, ...)");
    }
  }
  *origin += " cam0";
  if (!root["cam0"].IsMap()) fail(*origin, "expected a mapping of calibration keys");
  return root["cam0"];
}

}  // namespace

CameraCalibration parseCalibrationYaml(const std::string& text, const std::string& origin_in) {
  std::string origin = origin_in;
  YAML::Node root;
  try {
    // OpenCV's FileStorage writes a "%YAML:1.0" directive yaml-cpp does not take.
    root = YAML::Load(
        text.rfind("%YAML:", 0) == 0 ? text.substr(std::min(text.find('\n'), text.size())) : text);
  } catch (const YAML::Exception& e) {
    fail(origin, std::string("not valid YAML (") + e.what() + ")");
  }
  if (!root.IsMap()) fail(origin, "expected a YAML mapping of calibration keys");
  const YAML::Node node = cameraNode(root, &origin);
  const Layout& layout = layoutOf(node, origin);

  CameraCalibration calibration;
  calibration.model = readModel(node, origin);
  readIntrinsics(node, layout, origin, &calibration);
  // A five-element plumb_bob list of zeros is the same as none; keep it as the user wrote it.
  calibration.distortion = readDistortion(node, calibration.model, origin);
  if (node[kReadoutKey])
    calibration.rolling_shutter_readout_s = read<double>(node, kReadoutKey, origin);
  try {
    calibration.validate();
  } catch (const std::invalid_argument& e) {
    fail(origin, e.what());
  }
  return calibration;
}

CameraCalibration loadCalibrationYaml(const std::string& path) {
  std::ifstream file(path);
  if (!file) fail("'" + path + "'", "cannot open the file");
  std::stringstream text;
  text << file.rdbuf();
  return parseCalibrationYaml(text.str(), "'" + path + "'");
}

void saveCalibrationYaml(const CameraCalibration& calibration, const std::string& path) {
  YAML::Emitter out;
  out.SetDoublePrecision(17);
  out << YAML::BeginMap;
  out << YAML::Key << "width" << YAML::Value << calibration.width;
  out << YAML::Key << "height" << YAML::Value << calibration.height;
  out << YAML::Key << "fx" << YAML::Value << calibration.fx;
  out << YAML::Key << "fy" << YAML::Value << calibration.fy;
  out << YAML::Key << "cx" << YAML::Value << calibration.cx;
  out << YAML::Key << "cy" << YAML::Value << calibration.cy;
  out << YAML::Key << "distortion_model" << YAML::Value
      << geometry::distortionModelName(calibration.model);
  out << YAML::Key << "distortion" << YAML::Value << YAML::Flow << calibration.distortion;
  if (calibration.rolling_shutter_readout_s > 0.0) {
    out << YAML::Key << kReadoutKey << YAML::Value << calibration.rolling_shutter_readout_s;
  }
  out << YAML::EndMap;
  std::ofstream file(path);
  if (!file) throw std::runtime_error("cannot write calibration file '" + path + "'");
  file << "# Camera calibration (scale_drift_slam layout, see io/calibration_io.h)\n"
       << out.c_str() << "\n";
}

}  // namespace scale_drift_slam::io
