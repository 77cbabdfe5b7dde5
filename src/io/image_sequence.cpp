#include "scale_drift_slam/io/image_sequence.h"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>

#include "scale_drift_slam/io/calibration_io.h"

namespace scale_drift_slam::io {
namespace fs = std::filesystem;

FileImageSequence::FileImageSequence(std::vector<std::pair<double, std::string>> frames,
                                     std::optional<geometry::CameraCalibration> calibration,
                                     std::string kind)
    : frames_(std::move(frames)), calibration_(std::move(calibration)), kind_(std::move(kind)) {}

std::optional<SequenceFrame> FileImageSequence::next() {
  if (index_ >= frames_.size()) return std::nullopt;
  const auto& [timestamp, path] = frames_[index_++];
  SequenceFrame frame;
  frame.timestamp = timestamp;
  frame.source = path;
  frame.image = cv::imread(path, cv::IMREAD_UNCHANGED);
  return frame;
}

std::string FileImageSequence::describe() const {
  return kind_ + " sequence of " + std::to_string(frames_.size()) + " frames";
}

namespace {

[[noreturn]] void fail(const fs::path& where, const std::string& reason) {
  throw std::runtime_error("sequence '" + where.string() + "': " + reason);
}

std::vector<std::string> splitFields(const std::string& line, char separator) {
  std::vector<std::string> fields;
  std::stringstream stream(line);
  std::string field;
  if (separator == ' ') {
    while (stream >> field)
      fields.push_back(field);
  } else {
    while (std::getline(stream, field, separator)) {
      const auto first = field.find_first_not_of(" \t\r");
      const auto last = field.find_last_not_of(" \t\r");
      fields.push_back(first == std::string::npos ? "" : field.substr(first, last - first + 1));
    }
  }
  return fields;
}

/// Reads "<time> <file>" (TUM) or "<time_ns>,<file>" (EuRoC) lines; `time_scale` to seconds.
std::vector<std::pair<double, std::string>> readList(const fs::path& list, const fs::path& images,
                                                     char separator, double time_scale) {
  std::ifstream file(list);
  if (!file) fail(list, "cannot open the file");
  std::vector<std::pair<double, std::string>> frames;
  std::string line;
  for (int number = 1; std::getline(file, line); ++number) {
    if (line.empty() || line[0] == '#' || line.find_first_not_of(" \t\r") == std::string::npos) {
      continue;
    }
    const std::vector<std::string> fields = splitFields(line, separator);
    double time = 0.0;
    try {
      if (fields.size() < 2) throw std::invalid_argument("too few fields");
      std::size_t used = 0;
      time = std::stod(fields[0], &used) * time_scale;
      if (used != fields[0].size()) throw std::invalid_argument("bad number");
    } catch (const std::exception&) {
      fail(list, "line " + std::to_string(number) + " is not '<timestamp> <image>'");
    }
    frames.emplace_back(time, (images / fields[1]).string());
  }
  if (frames.empty()) fail(list, "lists no images");
  return frames;
}

std::unique_ptr<ImageSequence> openTum(const fs::path& dir) {
  std::optional<geometry::CameraCalibration> calibration;
  if (fs::exists(dir / "camera.yaml"))
    calibration = loadCalibrationYaml((dir / "camera.yaml").string());
  return std::make_unique<FileImageSequence>(readList(dir / "rgb.txt", dir, ' ', 1.0), calibration,
                                             "TUM");
}

std::unique_ptr<ImageSequence> openEuroc(const fs::path& mav0) {
  const fs::path cam = mav0 / "cam0";
  std::optional<geometry::CameraCalibration> calibration;
  if (fs::exists(cam / "sensor.yaml"))
    calibration = loadCalibrationYaml((cam / "sensor.yaml").string());
  return std::make_unique<FileImageSequence>(readList(cam / "data.csv", cam / "data", ',', 1e-9),
                                             calibration, "EuRoC");
}

std::unique_ptr<ImageSequence> openKitti(const fs::path& dir) {
  std::ifstream times(dir / "times.txt");
  if (!times) fail(dir / "times.txt", "cannot open the file");
  std::vector<std::pair<double, std::string>> frames;
  double t = 0.0;
  for (int i = 0; times >> t; ++i) {
    char name[16];
    std::snprintf(name, sizeof(name), "%06d.png", i);
    frames.emplace_back(t, (dir / "image_0" / name).string());
  }
  if (frames.empty()) fail(dir / "times.txt", "lists no times");
  std::optional<geometry::CameraCalibration> calibration;
  if (fs::exists(dir / "calib.txt")) {
    const cv::Mat first = cv::imread(frames.front().second, cv::IMREAD_UNCHANGED);
    if (first.empty()) fail(frames.front().second, "cannot read the first image");
    calibration = loadKittiCalibration((dir / "calib.txt").string(), first.cols, first.rows);
  }
  return std::make_unique<FileImageSequence>(std::move(frames), calibration, "KITTI");
}

}  // namespace

geometry::CameraCalibration loadKittiCalibration(const std::string& path, int width, int height) {
  std::ifstream file(path);
  if (!file) fail(path, "cannot open the file");
  std::string line;
  while (std::getline(file, line)) {
    if (line.rfind("P0:", 0) != 0) continue;
    std::stringstream stream(line.substr(3));
    double p[12];
    for (double& v : p) {
      if (!(stream >> v)) fail(path, "the P0 line needs 12 numbers");
    }
    geometry::CameraCalibration calibration;
    calibration.fx = p[0];
    calibration.cx = p[2];
    calibration.fy = p[5];
    calibration.cy = p[6];
    calibration.width = width;
    calibration.height = height;
    try {
      calibration.validate();
    } catch (const std::invalid_argument& e) {
      fail(path, e.what());
    }
    return calibration;
  }
  fail(path, "no 'P0:' line");
}

std::unique_ptr<ImageSequence> openImageFolder(const std::string& path) {
  const fs::path dir(path);
  if (!fs::is_directory(dir)) fail(dir, "is not a folder");
  if (fs::exists(dir / "rgb.txt")) return openTum(dir);
  if (fs::exists(dir / "cam0" / "data.csv")) return openEuroc(dir);
  if (fs::exists(dir / "mav0" / "cam0" / "data.csv")) return openEuroc(dir / "mav0");
  if (fs::exists(dir / "times.txt") && fs::is_directory(dir / "image_0")) return openKitti(dir);
  fail(dir,
       "not a TUM (rgb.txt), EuRoC (mav0/cam0/data.csv) or KITTI (image_0/, times.txt) "
       "folder");
}

}  // namespace scale_drift_slam::io
