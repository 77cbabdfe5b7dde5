#include "scale_drift_slam/io/calibration_io.h"

#include <fstream>
#include <sstream>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

namespace scale_drift_slam::io {
namespace {

using geometry::CameraCalibration;

[[noreturn]] void fail(const std::string& origin, const std::string& reason) {
  throw std::runtime_error("calibration " + origin + ": " + reason);
}

template <typename T>
T read(const YAML::Node& node, const std::string& key, const std::string& origin) {
  if (!node[key]) fail(origin, "missing key '" + key + "'");
  try {
    return node[key].as<T>();
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

std::string modelName(const YAML::Node& root, const std::string& origin) {
  if (root["distortion_model"]) return read<std::string>(root, "distortion_model", origin);
  if (root["camera_model"]) return read<std::string>(root, "camera_model", origin);
  return "plumb_bob";
}

}  // namespace

CameraCalibration parseCalibrationYaml(const std::string& text, const std::string& origin) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    fail(origin, std::string("not valid YAML (") + e.what() + ")");
  }
  if (!root.IsMap()) fail(origin, "expected a YAML mapping of calibration keys");

  CameraCalibration calibration;
  try {
    calibration.model = geometry::parseDistortionModel(modelName(root, origin));
  } catch (const std::invalid_argument& e) {
    fail(origin, e.what());
  }

  if (root["camera_matrix"]) {  // ROS camera_calibration_parsers layout
    const std::vector<double> k =
        readSequence(root["camera_matrix"]["data"], origin, "camera_matrix.data");
    if (k.size() != 9) fail(origin, "camera_matrix.data must hold 9 numbers");
    calibration.fx = k[0];
    calibration.cx = k[2];
    calibration.fy = k[4];
    calibration.cy = k[5];
    calibration.width = read<int>(root, "image_width", origin);
    calibration.height = read<int>(root, "image_height", origin);
    if (root["distortion_coefficients"]) {
      calibration.distortion = readSequence(root["distortion_coefficients"]["data"], origin,
                                            "distortion_coefficients.data");
    }
  } else if (root["intrinsics"]) {  // EuRoC / Kalibr layout
    const std::vector<double> k = readSequence(root["intrinsics"], origin, "intrinsics");
    if (k.size() != 4) fail(origin, "intrinsics must be [fu, fv, cu, cv]");
    calibration.fx = k[0];
    calibration.fy = k[1];
    calibration.cx = k[2];
    calibration.cy = k[3];
    const std::vector<double> size = readSequence(root["resolution"], origin, "resolution");
    if (size.size() != 2) fail(origin, "resolution must be [width, height]");
    calibration.width = static_cast<int>(size[0]);
    calibration.height = static_cast<int>(size[1]);
    if (root["distortion_coefficients"]) {
      calibration.distortion =
          readSequence(root["distortion_coefficients"], origin, "distortion_coefficients");
    }
  } else {  // our layout
    calibration.fx = read<double>(root, "fx", origin);
    calibration.fy = read<double>(root, "fy", origin);
    calibration.cx = read<double>(root, "cx", origin);
    calibration.cy = read<double>(root, "cy", origin);
    calibration.width = read<int>(root, "width", origin);
    calibration.height = read<int>(root, "height", origin);
    if (root["distortion"])
      calibration.distortion = readSequence(root["distortion"], origin, "distortion");
  }
  // A five-element plumb_bob list of zeros is the same as none; keep it as the user wrote it.
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
  out << YAML::EndMap;
  std::ofstream file(path);
  if (!file) throw std::runtime_error("cannot write calibration file '" + path + "'");
  file << "# Camera calibration (scale_drift_slam layout, see io/calibration_io.h)\n"
       << out.c_str() << "\n";
}

}  // namespace scale_drift_slam::io
