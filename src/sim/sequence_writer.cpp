#include "scale_drift_slam/sim/sequence_writer.h"

#include <cinttypes>
#include <cstdio>
#include <filesystem>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>

#include "scale_drift_slam/io/calibration_io.h"

namespace scale_drift_slam::sim {

TumSequenceWriter::TumSequenceWriter(const std::string& directory,
                                     const geometry::CameraCalibration& calibration,
                                     const std::string& description)
    : directory_(directory), description_(description) {
  std::error_code error;
  std::filesystem::create_directories(std::filesystem::path(directory) / "rgb", error);
  if (error) {
    throw std::runtime_error("cannot create output folder '" + directory + "': " + error.message());
  }
  io::saveCalibrationYaml(calibration, directory + "/camera.yaml");
  rgb_list_.open(directory + "/rgb.txt");
  if (!rgb_list_) throw std::runtime_error("cannot write '" + directory + "/rgb.txt'");
  rgb_list_ << "# rendered by scale_drift_slam render_sequence" << (description.empty() ? "" : ": ")
            << description << "\n# timestamp filename\n";
}

std::string TumSequenceWriter::formatStamp(std::int64_t stamp_ns) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%" PRId64 ".%09" PRId64, stamp_ns / 1000000000,
                stamp_ns % 1000000000);
  return buffer;
}

void TumSequenceWriter::add(const RenderedFrame& frame) {
  if (finished_) throw std::logic_error("TumSequenceWriter::add after finish");
  const std::string name = "rgb/" + formatStamp(frame.stamp_ns) + ".png";
  bool written = false;
  try {
    written = cv::imwrite(directory_ + "/" + name, frame.image);
  } catch (const cv::Exception&) {
    written = false;
  }
  if (!written) throw std::runtime_error("cannot write image '" + directory_ + "/" + name + "'");
  rgb_list_ << formatStamp(frame.stamp_ns) << ' ' << name << '\n';
  if (!rgb_list_) throw std::runtime_error("cannot write '" + directory_ + "/rgb.txt'");
  ground_truth_.push_back({frame.timestamp, frame.T_world_cam});
}

void TumSequenceWriter::finish() {
  if (finished_) return;
  finished_ = true;
  rgb_list_.close();
  io::saveTumTrajectory(directory_ + "/groundtruth.txt", ground_truth_,
                        "ground truth of a rendered sequence" +
                            (description_.empty() ? std::string() : ": " + description_));
}

TumSequenceWriter::~TumSequenceWriter() {
  try {
    finish();
  } catch (...) {  // a destructor must not throw; call finish() to see errors
  }
}

}  // namespace scale_drift_slam::sim
