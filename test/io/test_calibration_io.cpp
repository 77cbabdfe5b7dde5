// Calibration YAML: the three layouts users have (ours, ROS camera_calibration_parsers, EuRoC
// sensor.yaml) load to the same numbers; broken files fail with the file and the reason.

#include <fstream>

#include <gtest/gtest.h>

#include "scale_drift_slam/io/calibration_io.h"

namespace scale_drift_slam::io {
namespace {

using geometry::DistortionModel;

void expectFailure(const std::string& text, const std::string& reason) {
  try {
    parseCalibrationYaml(text, "test.yaml");
    ADD_FAILURE() << "accepted: " << text;
  } catch (const std::runtime_error& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("test.yaml"), std::string::npos) << message;
    EXPECT_NE(message.find(reason), std::string::npos) << message;
  }
}

TEST(CalibrationYaml, ReadsOurLayout) {
  const auto c = parseCalibrationYaml(
      "width: 640\nheight: 480\nfx: 500\nfy: 501\ncx: 320.5\ncy: 240.5\n"
      "distortion_model: radtan\ndistortion: [0.1, -0.05, 0.001, 0.002]\n");
  EXPECT_EQ(c.width, 640);
  EXPECT_EQ(c.height, 480);
  EXPECT_EQ(c.fx, 500);
  EXPECT_EQ(c.fy, 501);
  EXPECT_EQ(c.cx, 320.5);
  EXPECT_EQ(c.model, DistortionModel::kRadialTangential);
  ASSERT_EQ(c.distortion.size(), 4u);
  EXPECT_EQ(c.distortion[3], 0.002);
}

TEST(CalibrationYaml, ReadsRosCameraInfoLayout) {
  const auto c = parseCalibrationYaml(
      "image_width: 640\nimage_height: 480\ncamera_name: narrow_stereo\n"
      "camera_matrix:\n  rows: 3\n  cols: 3\n  data: [517.3, 0, 318.6, 0, 516.5, 255.3, 0, 0, 1]\n"
      "distortion_model: plumb_bob\n"
      "distortion_coefficients:\n  rows: 1\n  cols: 5\n"
      "  data: [0.2624, -0.9531, -0.0054, 0.0026, 1.1633]\n");
  EXPECT_EQ(c.fx, 517.3);
  EXPECT_EQ(c.fy, 516.5);
  EXPECT_EQ(c.cx, 318.6);
  EXPECT_EQ(c.cy, 255.3);
  EXPECT_EQ(c.distortion.size(), 5u);
}

TEST(CalibrationYaml, ReadsEurocSensorLayout) {
  const auto c = parseCalibrationYaml(
      "sensor_type: camera\nrate_hz: 20\nresolution: [752, 480]\ncamera_model: pinhole\n"
      "intrinsics: [458.654, 457.296, 367.215, 248.375]\n"
      "distortion_model: radial-tangential\n"
      "distortion_coefficients: [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]\n");
  EXPECT_EQ(c.width, 752);
  EXPECT_EQ(c.fx, 458.654);
  EXPECT_EQ(c.cy, 248.375);
  EXPECT_EQ(c.model, DistortionModel::kRadialTangential);
  EXPECT_EQ(c.distortion.size(), 4u);
}

TEST(CalibrationYaml, SaveThenLoadIsExact) {
  geometry::CameraCalibration c;
  c.model = DistortionModel::kEquidistant;
  c.fx = 190.97847715128717;
  c.fy = 190.9733070521226;
  c.cx = 254.93170605935475;
  c.cy = 256.8974428996504;
  c.width = 512;
  c.height = 512;
  c.distortion = {0.0034823894022493434, 0.0007150348452162257, -0.0020532361418706202,
                  0.00020293673591811182};
  const std::string path = std::string(SDS_TEST_OUTPUT_DIR) + "/calibration_roundtrip.yaml";
  saveCalibrationYaml(c, path);
  const auto loaded = loadCalibrationYaml(path);
  EXPECT_EQ(loaded.model, c.model);
  EXPECT_EQ(loaded.fx, c.fx);
  EXPECT_EQ(loaded.cy, c.cy);
  EXPECT_EQ(loaded.distortion, c.distortion);
}

TEST(CalibrationYaml, BrokenFilesFailWithTheReason) {
  expectFailure("width: 640\nheight: 480\nfx: 500\nfy: 500\ncx: 320\n", "missing key 'cy'");
  expectFailure("width: 640\nheight: 480\nfx: .nan\nfy: 500\ncx: 320\ncy: 240\n",
                "fx is not a finite number");
  expectFailure("width: 640\nheight: 480\nfx: -5\nfy: 500\ncx: 320\ncy: 240\n",
                "focal lengths must be positive");
  expectFailure("width: 640\nheight: 480\nfx: 5\nfy: 500\ncx: 320\ncy: 240\ndistortion: [1, 2]\n",
                "plumb_bob takes 0, 4 or 5 coefficients");
  expectFailure("width: 640\nheight: 480\nfx: abc\nfy: 500\ncx: 320\ncy: 240\n",
                "key 'fx' does not hold the expected kind of value");
  expectFailure("{{{ not yaml", "not valid YAML");
  expectFailure("\x89PNG\r\n\x1a\n binary", "");
  expectFailure("- just\n- a list\n", "expected a YAML mapping");
  expectFailure("width: 640\nheight: 480\nfx: 5\nfy: 5\ncx: 3\ncy: 2\ndistortion_model: zoom\n",
                "unknown distortion model 'zoom'");
  EXPECT_THROW(loadCalibrationYaml("/nonexistent/calibration.yaml"), std::runtime_error);
}

}  // namespace
}  // namespace scale_drift_slam::io
