#include "scale_drift_slam/io/image_sequence.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>

#include "scale_drift_slam/io/calibration_io.h"

namespace scale_drift_slam::io {
namespace fs = std::filesystem;

FileImageSequence::FileImageSequence(std::vector<std::pair<double, std::string>> frames,
                                     std::optional<geometry::CameraCalibration> calibration,
                                     std::string kind, std::vector<std::string> warnings)
    : frames_(std::move(frames)),
      warnings_(std::move(warnings)),
      calibration_(std::move(calibration)),
      kind_(std::move(kind)) {}

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

/// A stamp field: a finite number (std::stod also takes "nan" and "inf": refused).
double parseStamp(const std::string& field, double time_scale, const std::string& origin,
                  int line) {
  double time = 0.0;
  try {
    std::size_t used = 0;
    time = std::stod(field, &used) * time_scale;
    if (used != field.size()) throw std::invalid_argument("bad number");
  } catch (const std::exception&) {
    time = std::numeric_limits<double>::quiet_NaN();
  }
  if (!std::isfinite(time)) {
    fail(origin,
         "line " + std::to_string(line) + ": the timestamp '" + field + "' is not a finite number");
  }
  return time;
}

struct ListedFrame {
  double time;
  std::string path;
  int line;
};

/// Sorts by stamp (stable) and drops repeated stamps; says what it did.
std::vector<std::string> sortStamps(std::vector<ListedFrame>* frames, const std::string& origin) {
  std::vector<std::string> warnings;
  int back = 0, first_back = 0;
  for (std::size_t i = 1; i < frames->size(); ++i) {
    if ((*frames)[i].time < (*frames)[i - 1].time && back++ == 0) first_back = (*frames)[i].line;
  }
  if (frames->size() > 1 && frames->front().time == frames->back().time && back == 0) {
    bool all_equal = true;
    for (const ListedFrame& f : *frames)
      all_equal = all_equal && f.time == frames->front().time;
    if (all_equal) {
      warnings.push_back("'" + origin + "': all " + std::to_string(frames->size()) +
                         " timestamps are equal: only the first frame is used");
    }
  }
  if (back > 0) {
    std::stable_sort(frames->begin(), frames->end(),
                     [](const ListedFrame& a, const ListedFrame& b) { return a.time < b.time; });
    warnings.push_back("'" + origin + "': " + std::to_string(back) +
                       " timestamp(s) go back in time (first at line " +
                       std::to_string(first_back) + "): the frames are read sorted by timestamp");
  }
  std::vector<ListedFrame> unique;
  int duplicates = 0, first_duplicate = 0;
  for (const ListedFrame& f : *frames) {
    if (!unique.empty() && f.time == unique.back().time) {
      if (duplicates++ == 0) first_duplicate = f.line;
      continue;
    }
    unique.push_back(f);
  }
  if (duplicates > 0 && unique.size() > 1) {
    warnings.push_back("'" + origin + "': " + std::to_string(duplicates) +
                       " frame(s) repeat an earlier timestamp (first at line " +
                       std::to_string(first_duplicate) +
                       "): dropped, the first frame of each timestamp is used");
  }
  *frames = std::move(unique);
  return warnings;
}

}  // namespace

FrameList parseFrameList(const std::string& text, ListFormat format, const std::string& origin,
                         const std::string& image_dir) {
  std::istringstream stream(text);
  std::vector<ListedFrame> listed;
  std::string line;
  for (int number = 1; std::getline(stream, line); ++number) {
    if (line.empty() || line[0] == '#' || line.find_first_not_of(" \t\r") == std::string::npos) {
      continue;
    }
    if (format == ListFormat::kKittiTimes) {
      const std::vector<std::string> fields = splitFields(line, ' ');
      if (fields.size() != 1)
        fail(origin, "line " + std::to_string(number) + " is not '<seconds>'");
      char name[32];
      std::snprintf(name, sizeof(name), "%06zu.png", listed.size());
      listed.push_back({parseStamp(fields[0], 1.0, origin, number),
                        (fs::path(image_dir) / name).string(), number});
      continue;
    }
    const bool tum = format == ListFormat::kTum;
    const std::vector<std::string> fields = splitFields(line, tum ? ' ' : ',');
    if (fields.size() < 2 || fields[1].empty()) {
      fail(origin, "line " + std::to_string(number) + " is not '<timestamp>" + (tum ? " " : ",") +
                       "<image>'");
    }
    listed.push_back({parseStamp(fields[0], tum ? 1.0 : 1e-9, origin, number),
                      (fs::path(image_dir) / fields[1]).string(), number});
  }
  if (listed.empty()) fail(origin, "lists no images");
  FrameList list;
  list.warnings = sortStamps(&listed, origin);
  for (ListedFrame& f : listed)
    list.frames.emplace_back(f.time, std::move(f.path));
  return list;
}

namespace {

FrameList readList(const fs::path& list, ListFormat format, const fs::path& images) {
  std::ifstream file(list);
  if (!file) fail(list, "cannot open the file");
  std::stringstream text;
  text << file.rdbuf();
  return parseFrameList(text.str(), format, list.string(), images.string());
}

std::unique_ptr<ImageSequence> openTum(const fs::path& dir) {
  std::optional<geometry::CameraCalibration> calibration;
  if (fs::exists(dir / "camera.yaml"))
    calibration = loadCalibrationYaml((dir / "camera.yaml").string());
  FrameList list = readList(dir / "rgb.txt", ListFormat::kTum, dir);
  return std::make_unique<FileImageSequence>(std::move(list.frames), calibration, "TUM",
                                             std::move(list.warnings));
}

std::unique_ptr<ImageSequence> openEuroc(const fs::path& mav0) {
  const fs::path cam = mav0 / "cam0";
  std::optional<geometry::CameraCalibration> calibration;
  if (fs::exists(cam / "sensor.yaml"))
    calibration = loadCalibrationYaml((cam / "sensor.yaml").string());
  FrameList list = readList(cam / "data.csv", ListFormat::kEuroc, cam / "data");
  return std::make_unique<FileImageSequence>(std::move(list.frames), calibration, "EuRoC",
                                             std::move(list.warnings));
}

std::unique_ptr<ImageSequence> openKitti(const fs::path& dir) {
  FrameList list = readList(dir / "times.txt", ListFormat::kKittiTimes, dir / "image_0");
  std::vector<std::pair<double, std::string>>& frames = list.frames;
  std::optional<geometry::CameraCalibration> calibration;
  if (fs::exists(dir / "calib.txt")) {
    const cv::Mat first = cv::imread(frames.front().second, cv::IMREAD_UNCHANGED);
    if (first.empty()) fail(frames.front().second, "cannot read the first image");
    calibration = loadKittiCalibration((dir / "calib.txt").string(), first.cols, first.rows);
  }
  return std::make_unique<FileImageSequence>(std::move(frames), calibration, "KITTI",
                                             std::move(list.warnings));
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
