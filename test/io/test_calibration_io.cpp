// Calibration YAML: the layouts users have (ours, ROS camera_calibration_parsers, CameraInfo as
// echoed, EuRoC sensor.yaml, Kalibr camchain, k1 k2 p1 p2 keys) load to the same numbers and
// really read their distortion (a point projects where the lens formula puts it); broken,
// misspelt or absurd files fail with the file and the reason (issue 17).

#include <cmath>
#include <fstream>

#include <gtest/gtest.h>

#include "scale_drift_slam/geometry/camera_model.h"
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
  EXPECT_EQ(loaded.rolling_shutter_readout_s, 0.0);
  c.rolling_shutter_readout_s = 0.0213;  // a rolling shutter's readout is kept too
  saveCalibrationYaml(c, path);
  EXPECT_EQ(loadCalibrationYaml(path).rolling_shutter_readout_s, 0.0213);
}

// No layout has a key for a rolling shutter's readout time: every one accepts ours.
TEST(CalibrationYaml, EveryLayoutTakesARollingShutterReadout) {
  EXPECT_EQ(parseCalibrationYaml("width: 640\nheight: 480\nfx: 500\nfy: 500\ncx: 320\ncy: 240\n"
                                 "rolling_shutter_readout_s: 0.03\n")
                .rolling_shutter_readout_s,
            0.03);
  EXPECT_EQ(parseCalibrationYaml("sensor_type: camera\nresolution: [752, 480]\n"
                                 "intrinsics: [458.6, 457.3, 367.2, 248.4]\n"
                                 "distortion_coefficients: [0, 0, 0, 0]\n"
                                 "rolling_shutter_readout_s: 0.015\n")
                .rolling_shutter_readout_s,
            0.015);
  expectFailure(
      "width: 640\nheight: 480\nfx: 500\nfy: 500\ncx: 320\ncy: 240\n"
      "rolling_shutter_readout_s: -0.03\n",
      "rolling_shutter_readout_s");
  expectFailure(
      "width: 640\nheight: 480\nfx: 500\nfy: 500\ncx: 320\ncy: 240\n"
      "rolling_shutter_readout: 0.03\n",
      "did you mean 'rolling_shutter_readout_s'");
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

// Where the point (0.3, -0.2, 1) lands through the lens formulas themselves (not the code under
// test): plumb_bob with k1 k2 p1 p2 k3, equidistant with k1..k4; fx 500 fy 490 cx 320 cy 240.
const Eigen::Vector3d kPoint(0.3, -0.2, 1.0);

Eigen::Vector2d radtanPixel(const std::vector<double>& d) {
  const double x = 0.3, y = -0.2, r2 = x * x + y * y;
  const double k3 = d.size() > 4 ? d[4] : 0.0;
  const double radial = 1 + d[0] * r2 + d[1] * r2 * r2 + k3 * r2 * r2 * r2;
  const double xd = x * radial + 2 * d[2] * x * y + d[3] * (r2 + 2 * x * x);
  const double yd = y * radial + d[2] * (r2 + 2 * y * y) + 2 * d[3] * x * y;
  return {500 * xd + 320, 490 * yd + 240};
}

Eigen::Vector2d equidistantPixel(const std::vector<double>& k) {
  const double x = 0.3, y = -0.2, r = std::hypot(x, y), t = std::atan(r), t2 = t * t;
  const double td =
      t * (1 + k[0] * t2 + k[1] * t2 * t2 + k[2] * t2 * t2 * t2 + k[3] * t2 * t2 * t2 * t2);
  return {500 * x * td / r + 320, 490 * y * td / r + 240};
}

void expectProjection(const std::string& text, const Eigen::Vector2d& expected) {
  SCOPED_TRACE(text);
  const geometry::CameraCalibration c = parseCalibrationYaml(text, "test.yaml");
  const auto pixel = geometry::makeCameraModel(c)->project(kPoint);
  ASSERT_TRUE(pixel.has_value());
  EXPECT_NEAR((*pixel - expected).norm(), 0.0, 1e-6)
      << pixel->transpose() << " vs " << expected.transpose();
  // And not where the same camera without distortion would put it (30+ px away here).
  EXPECT_GT((expected - Eigen::Vector2d(500 * 0.3 + 320, 490 * -0.2 + 240)).norm(), 5.0);
}

const std::vector<double> kRadtan = {-0.28, 0.07, 0.002, -0.001, 0.01};
const std::vector<double> kFisheye = {0.05, -0.02, 0.004, -0.001};

TEST(CalibrationYaml, EveryLayoutReadsItsDistortion) {
  const std::string ours = "width: 640\nheight: 480\nfx: 500\nfy: 490\ncx: 320\ncy: 240\n";
  // Issue 17: `D:`, `k1..p2` and Kalibr's `distortion_coeffs` were read as no distortion.
  expectProjection(ours + "D: [-0.28, 0.07, 0.002, -0.001, 0.01]\n", radtanPixel(kRadtan));
  expectProjection(ours + "distortion: [-0.28, 0.07, 0.002, -0.001, 0.01]\n", radtanPixel(kRadtan));
  expectProjection(ours + "k1: -0.28\nk2: 0.07\np1: 0.002\np2: -0.001\nk3: 0.01\n",
                   radtanPixel(kRadtan));
  expectProjection(ours + "k1: -0.28\nk2: 0.07\np1: 0.002\np2: -0.001\n",
                   radtanPixel({-0.28, 0.07, 0.002, -0.001}));
  expectProjection("%YAML:1.0\n" + ours + "k1: -0.28\nk2: 0.07\np1: 0.002\np2: -0.001\n",
                   radtanPixel({-0.28, 0.07, 0.002, -0.001}));
  expectProjection(
      ours + "distortion_model: equidistant\nk1: 0.05\nk2: -0.02\nk3: 0.004\nk4: -0.001\n",
      equidistantPixel(kFisheye));
  // ROS camera_calibration_parsers.
  expectProjection(
      "image_width: 640\nimage_height: 480\ncamera_name: cam\n"
      "camera_matrix: {rows: 3, cols: 3, data: [500, 0, 320, 0, 490, 240, 0, 0, 1]}\n"
      "distortion_model: plumb_bob\n"
      "distortion_coefficients: {rows: 1, cols: 5, data: [-0.28, 0.07, 0.002, -0.001, 0.01]}\n"
      "rectification_matrix: {rows: 3, cols: 3, data: [1, 0, 0, 0, 1, 0, 0, 0, 1]}\n"
      "projection_matrix: {rows: 3, cols: 4, data: [500, 0, 320, 0, 0, 490, 240, 0, 0, 0, 1, 0]}\n",
      radtanPixel(kRadtan));
  // A CameraInfo as `rostopic echo` prints it.
  expectProjection(
      "header: {seq: 1, stamp: {secs: 0, nsecs: 0}, frame_id: cam}\nheight: 480\nwidth: 640\n"
      "distortion_model: plumb_bob\nD: [-0.28, 0.07, 0.002, -0.001, 0.01]\n"
      "K: [500, 0, 320, 0, 490, 240, 0, 0, 1]\nR: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n"
      "P: [500, 0, 320, 0, 0, 490, 240, 0, 0, 0, 1, 0]\nbinning_x: 0\nbinning_y: 0\n"
      "roi: {x_offset: 0, y_offset: 0, height: 0, width: 0, do_rectify: false}\n",
      radtanPixel(kRadtan));
  // EuRoC sensor.yaml.
  expectProjection(
      "%YAML:1.0\nsensor_type: camera\ncomment: VI-Sensor cam0\n"
      "T_BS: {cols: 4, rows: 4, data: [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]}\n"
      "rate_hz: 20\nresolution: [640, 480]\ncamera_model: pinhole\n"
      "intrinsics: [500, 490, 320, 240]\ndistortion_model: radial-tangential\n"
      "distortion_coefficients: [-0.28, 0.07, 0.002, -0.001]\n",
      radtanPixel({-0.28, 0.07, 0.002, -0.001}));
  // Kalibr camchain: radtan and equidistant.
  const std::string kalibr =
      "cam0:\n  cam_overlaps: []\n  camera_model: pinhole\n"
      "  intrinsics: [500, 490, 320, 240]\n  resolution: [640, 480]\n  rostopic: /cam0/image_raw\n"
      "  T_cam_imu:\n  - [1, 0, 0, 0]\n  - [0, 1, 0, 0]\n  - [0, 0, 1, 0]\n  - [0, 0, 0, 1]\n"
      "  timeshift_cam_imu: 0.0\n";
  expectProjection(kalibr +
                       "  distortion_model: radtan\n"
                       "  distortion_coeffs: [-0.28, 0.07, 0.002, -0.001]\n",
                   radtanPixel({-0.28, 0.07, 0.002, -0.001}));
  expectProjection(kalibr +
                       "  distortion_model: equidistant\n"
                       "  distortion_coeffs: [0.05, -0.02, 0.004, -0.001]\n",
                   equidistantPixel(kFisheye));
  // Kalibr's single-camera output (no cam0 level).
  expectProjection(
      "camera_model: pinhole\nintrinsics: [500, 490, 320, 240]\n"
      "resolution: [640, 480]\ndistortion_model: radtan\n"
      "distortion_coeffs: [-0.28, 0.07, 0.002, -0.001]\n",
      radtanPixel({-0.28, 0.07, 0.002, -0.001}));
}

TEST(CalibrationYaml, MisspeltAndUnknownKeysAreErrors) {
  const std::string ours = "width: 640\nheight: 480\nfx: 500\nfy: 490\ncx: 320\ncy: 240\n";
  // Issue 17: read as plumb_bob with the fisheye coefficients, exit 0.
  expectFailure(ours + "distortion_modle: equidistant\ndistortion: [0.05, -0.02, 0.004, -0.001]\n",
                "unknown key 'distortion_modle' (did you mean 'distortion_model'?)");
  expectFailure(ours + "distortion_modle: equidistant\n",
                "accepted layouts: ROS camera_calibration");
  expectFailure(ours + "distortion_coefs: [0.1, 0, 0, 0]\n",
                "unknown key 'distortion_coefs' (did you mean 'distortion_coeffs'?)");
  expectFailure(ours + "Fx: 3\n", "unknown key 'Fx' (did you mean 'fx'?)");
  expectFailure(ours + "lens: wide\n", "unknown key 'lens' in a file read as ours");
  expectFailure("cam0: {intrinsics: [500, 490, 320, 240], resolution: [640, 480]}\nimu0: {}\n",
                "key 'imu0' next to 'cam0'");
  expectFailure(ours + "D: [0.1, 0, 0, 0]\nk1: 0.1\n", "the distortion is given twice");
  expectFailure(ours + "k1: 0.1\nk2: 0\np1: 0\np2: 0\nk4: 0\n", "'k4' does not belong");
  expectFailure(ours + "k1: 0.1\nk2: 0\n", "missing key 'p1'");
  expectFailure(ours + "distortion_model: equidistant\nk1: 0.1\nk2: 0\nk3: 0\nk4: 0\np1: 0\n",
                "'p1' does not belong");
  expectFailure(
      "camera_model: omni\nintrinsics: [500, 490, 320, 240]\nresolution: [640, 480]\n"
      "distortion_model: radtan\ndistortion_coeffs: [0, 0, 0, 0]\n",
      "camera_model 'omni' is not supported");
  expectFailure(
      "camera_matrix: [500, 0, 320, 0, 490, 240, 0, 0, 1]\nimage_width: 640\n"
      "image_height: 480\n",
      "'camera_matrix' must be a mapping");
}

TEST(CalibrationYaml, PhysicallyAbsurdValuesAreErrors) {
  const std::string size = "width: 640\nheight: 480\n";
  // Issue 17: fx = 1e300 was accepted; every frame stayed "initializing".
  expectFailure(size + "fx: 1e300\nfy: 500\ncx: 320\ncy: 240\n", "more than 100x");
  expectFailure(size + "fx: 64001\nfy: 500\ncx: 320\ncy: 240\n", "more than 100x");
  expectFailure(size + "fx: 0\nfy: 500\ncx: 320\ncy: 240\n", "focal lengths must be positive");
  expectFailure(size + "fx: .inf\nfy: 500\ncx: 320\ncy: 240\n", "fx is not a finite number");
  expectFailure(size + "fx: 500\nfy: 500\ncx: 3200\ncy: 240\n", "far outside");
  expectFailure(size + "fx: 500\nfy: 500\ncx: 320\ncy: -600\n", "far outside");
  expectFailure(size + "fx: 500\nfy: 500\ncx: 320\ncy: 240\nD: [.nan, 0, 0, 0]\n",
                "distortion coefficient 0 is not a finite number");
  expectFailure(size + "fx: 500\nfy: 500\ncx: 320\ncy: 240\nk1: .inf\nk2: 0\np1: 0\np2: 0\n",
                "distortion coefficient 0 is not a finite number");
  expectFailure("width: 1e300\nheight: 480\nfx: 500\nfy: 500\ncx: 320\ncy: 240\n",
                "width must be a whole number of pixels");
  expectFailure("width: 640.5\nheight: 480\nfx: 500\nfy: 500\ncx: 320\ncy: 240\n",
                "width must be a whole number of pixels");
  expectFailure("intrinsics: [500, 490, 320, 240]\nresolution: [.nan, 480]\n",
                "resolution[0] must be a whole number");
  // Found by the fuzz test: finite but absurd coefficients overflowed the projection.
  expectFailure(size + "fx: 500\nfy: 500\ncx: 320\ncy: 240\nk1: 0\nk2: 0\np1: 0\np2: 1e308\n",
                "distortion coefficient 3 (1e+308) is beyond any lens's");
  // Still accepted: a long lens (50x the width) and a principal point off the centre.
  EXPECT_NO_THROW(parseCalibrationYaml(size + "fx: 32000\nfy: 32000\ncx: 500\ncy: 100\n"));
}

}  // namespace
}  // namespace scale_drift_slam::io
