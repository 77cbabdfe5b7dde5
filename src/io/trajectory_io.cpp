#include "scale_drift_slam/io/trajectory_io.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>

namespace scale_drift_slam::io {
namespace {

[[noreturn]] void fail(const std::string& path, int line, const std::string& reason) {
  throw std::runtime_error("trajectory '" + path + "'" +
                           (line > 0 ? " line " + std::to_string(line) : "") + ": " + reason);
}

}  // namespace

std::vector<StampedPose> loadTrajectory(const std::string& path) {
  std::ifstream file(path);
  if (!file) fail(path, 0, "cannot open the file");
  std::vector<StampedPose> poses;
  std::string line;
  int line_number = 0;
  while (std::getline(file, line)) {
    ++line_number;
    const size_t start = line.find_first_not_of(" \t\r");
    if (start == std::string::npos || line[start] == '#') continue;
    const bool euroc = line.find(',') != std::string::npos;
    if (euroc) {
      for (char& c : line) {
        if (c == ',') c = ' ';
      }
    }
    std::istringstream fields(line);
    double v[8];
    for (double& value : v) {
      if (!(fields >> value)) {
        fail(path, line_number, "expected 8 numbers (TUM: t tx ty tz qx qy qz qw)");
      }
    }
    StampedPose pose;
    Eigen::Quaterniond q;
    if (euroc) {  // ns; p; q in w x y z order
      pose.timestamp = v[0] * 1e-9;
      q = Eigen::Quaterniond(v[4], v[5], v[6], v[7]);
    } else {
      pose.timestamp = v[0];
      q = Eigen::Quaterniond(v[7], v[4], v[5], v[6]);
    }
    const double norm = q.norm();
    if (!(norm > 0.5 && norm < 1.5)) fail(path, line_number, "the quaternion is not unit length");
    pose.T_world_cam = geometry::SE3(q, Eigen::Vector3d(v[1], v[2], v[3]));
    if (!pose.T_world_cam.translation().allFinite() || !std::isfinite(pose.timestamp)) {
      fail(path, line_number, "non-finite value");
    }
    poses.push_back(pose);
  }
  return poses;
}

std::size_t sortAndDropRepeatedStamps(std::vector<StampedPose>* poses, std::size_t* reordered) {
  std::size_t back = 0;
  for (std::size_t i = 1; i < poses->size(); ++i)
    back += (*poses)[i].timestamp < (*poses)[i - 1].timestamp ? 1 : 0;
  if (reordered) *reordered = back;
  std::stable_sort(poses->begin(), poses->end(), [](const StampedPose& a, const StampedPose& b) {
    return a.timestamp < b.timestamp;
  });
  const auto end = std::unique(
      poses->begin(), poses->end(),
      [](const StampedPose& a, const StampedPose& b) { return a.timestamp == b.timestamp; });
  const std::size_t dropped = static_cast<std::size_t>(poses->end() - end);
  poses->erase(end, poses->end());
  return dropped;
}

void saveTumTrajectory(const std::string& path, const std::vector<StampedPose>& poses,
                       const std::string& header_comment) {
  std::ofstream file(path);
  if (!file) throw std::runtime_error("cannot write trajectory '" + path + "'");
  if (!header_comment.empty()) file << "# " << header_comment << "\n";
  file << "# timestamp tx ty tz qx qy qz qw (camera pose in the world)\n";
  file << std::setprecision(17);
  for (const StampedPose& pose : poses) {
    const Eigen::Vector3d& t = pose.T_world_cam.translation();
    const Eigen::Quaterniond& q = pose.T_world_cam.rotation();
    file << std::fixed << std::setprecision(9) << pose.timestamp << std::defaultfloat
         << std::setprecision(17) << ' ' << t.x() << ' ' << t.y() << ' ' << t.z() << ' ' << q.x()
         << ' ' << q.y() << ' ' << q.z() << ' ' << q.w() << '\n';
  }
  if (!file) throw std::runtime_error("error while writing trajectory '" + path + "'");
}

}  // namespace scale_drift_slam::io
