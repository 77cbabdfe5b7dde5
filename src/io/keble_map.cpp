#include "scale_drift_slam/io/keble_map.h"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <stdexcept>
#include <vector>

#include <Eigen/LU>

namespace scale_drift_slam::io {
namespace {

enum class Section { kNone, kPoses, kScale, kLoopId, kPoints, kObs };

[[noreturn]] void fail(const std::string& path, int line, const std::string& reason) {
  throw std::runtime_error("Keble map '" + path + "'" +
                           (line > 0 ? " line " + std::to_string(line) : "") + ": " + reason);
}

/// Parses exactly `count` finite numbers separated by blanks, commas or colons.
bool parseNumbers(std::string text, int count, double* out) {
  std::replace(text.begin(), text.end(), ',', ' ');
  std::replace(text.begin(), text.end(), ':', ' ');
  const char* cursor = text.c_str();
  for (int i = 0; i < count; ++i) {
    char* end = nullptr;
    errno = 0;
    out[i] = std::strtod(cursor, &end);
    if (end == cursor || errno == ERANGE || !std::isfinite(out[i])) {
      return false;
    }
    cursor = end;
  }
  while (*cursor == ' ' || *cursor == '\t' || *cursor == '\r') {
    ++cursor;
  }
  return *cursor == '\0';
}

bool isIndex(double value) {
  return value >= 0.0 && value < 4e9 && value == std::floor(value);
}

struct RawObservation {
  std::size_t point;
  std::size_t frame;
  Eigen::Vector2d uv;
  int line;
};

/// Everything the file holds, before it becomes a map.
struct RawKeble {
  std::vector<geometry::SE3> poses;
  std::vector<Eigen::Vector3d> points;
  std::vector<RawObservation> observations;
  std::optional<double> scale;
  std::optional<double> loop_id;
  int loop_line = 0;
  int scale_line = 0;
};

geometry::SE3 poseFromRows(const std::string& path, int line,
                           const std::vector<std::array<double, 4>>& rows) {
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      R(r, c) = rows[r][c];
    }
    t[r] = rows[r][3];
  }
  const double orthogonality = (R * R.transpose() - Eigen::Matrix3d::Identity()).norm();
  if (orthogonality > 1e-3 || R.determinant() < 0.0) {
    fail(path, line,
         "pose is not a rotation (|R R^T - I| = " + std::to_string(orthogonality) +
             ", det = " + std::to_string(R.determinant()) + ")");
  }
  return geometry::SE3(R, t);  // re-orthonormalised through the quaternion
}

void parseLine(const std::string& path, int line_number, const std::string& line, Section section,
               RawKeble& raw, std::vector<std::array<double, 4>>& pose_rows) {
  double v[4];
  switch (section) {
    case Section::kNone:
      fail(path, line_number, "data before the first section name");
    case Section::kPoses: {
      if (!parseNumbers(line, 4, v)) {
        fail(path, line_number, "expected 4 numbers (r r r t)");
      }
      pose_rows.push_back({v[0], v[1], v[2], v[3]});
      if (pose_rows.size() == 3) {
        raw.poses.push_back(poseFromRows(path, line_number, pose_rows));
        pose_rows.clear();
      }
      return;
    }
    case Section::kScale:
      if (raw.scale || !parseNumbers(line, 1, v)) {
        fail(path, line_number, "expected one scale");
      }
      if (!(v[0] > 0.0)) {
        fail(path, line_number, "the loop scale must be > 0");
      }
      raw.scale = v[0];
      raw.scale_line = line_number;
      return;
    case Section::kLoopId:
      if (raw.loop_id || !parseNumbers(line, 1, v) || !isIndex(v[0])) {
        fail(path, line_number, "expected one non-negative integer loop id");
      }
      raw.loop_id = v[0];
      raw.loop_line = line_number;
      return;
    case Section::kPoints:
      if (!parseNumbers(line, 3, v)) {
        fail(path, line_number, "expected 3 numbers (x y z)");
      }
      raw.points.emplace_back(v[0], v[1], v[2]);
      return;
    case Section::kObs:
      if (!parseNumbers(line, 4, v) || !isIndex(v[0]) || !isIndex(v[1])) {
        fail(path, line_number, "expected 'point_id, keyframe_id : u v'");
      }
      raw.observations.push_back({static_cast<std::size_t>(v[0]), static_cast<std::size_t>(v[1]),
                                  Eigen::Vector2d(v[2], v[3]), line_number});
      return;
  }
}

RawKeble readRaw(const std::string& path) {
  std::ifstream file(path);
  if (!file) {
    fail(path, 0, "cannot open the file");
  }
  RawKeble raw;
  Section section = Section::kNone;
  std::vector<std::array<double, 4>> pose_rows;
  std::string line;
  int line_number = 0;
  while (std::getline(file, line)) {
    ++line_number;
    const std::size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos) {
      continue;
    }
    const std::string word = line.substr(first, line.find_last_not_of(" \t\r") - first + 1);
    const Section next = word == "Poses"    ? Section::kPoses
                         : word == "Scale"  ? Section::kScale
                         : word == "LoopId" ? Section::kLoopId
                         : word == "Points" ? Section::kPoints
                         : word == "Obs"    ? Section::kObs
                                            : Section::kNone;
    if (next != Section::kNone) {
      if (!pose_rows.empty()) {
        fail(path, line_number, "a pose block has fewer than 3 rows");
      }
      section = next;
      continue;
    }
    parseLine(path, line_number, line, section, raw, pose_rows);
  }
  if (file.bad()) {
    fail(path, line_number, "read error");
  }
  if (!pose_rows.empty()) {
    fail(path, line_number, "a pose block has fewer than 3 rows");
  }
  return raw;
}

}  // namespace

KebleMap loadKebleMap(const std::string& path, const KebleCamera& camera) {
  const RawKeble raw = readRaw(path);
  if (raw.poses.size() < 3) {
    fail(path, 0, "needs at least 3 poses in a 'Poses' section");
  }
  if (!raw.scale) {
    fail(path, 0, "no 'Scale' section");
  }
  if (!raw.loop_id) {
    fail(path, 0, "no 'LoopId' section");
  }
  if (raw.points.empty()) {
    fail(path, 0, "no 'Points' section");
  }
  const std::size_t num_keyframes = raw.poses.size() - 1;  // the last pose is the current camera
  if (*raw.loop_id >= num_keyframes - 1) {
    fail(path, raw.loop_line,
         "loop id " + std::to_string(static_cast<long>(*raw.loop_id)) +
             " leaves no keyframes to correct");
  }
  if (!(camera.fx != 0.0 && camera.fy != 0.0 && std::isfinite(camera.fx) &&
        std::isfinite(camera.fy) && std::isfinite(camera.cx) && std::isfinite(camera.cy))) {
    throw std::invalid_argument("Keble map: the camera needs finite, non-zero focal lengths");
  }

  KebleMap keble;
  keble.camera = camera;
  keble.loop_scale = *raw.scale;
  keble.loop_keyframe = static_cast<map::KeyframeId>(*raw.loop_id);
  keble.current_id = static_cast<map::KeyframeId>(num_keyframes);
  keble.T_current_world = raw.poses.back();
  for (std::size_t i = 0; i < raw.points.size(); ++i) {
    keble.map.addPoint({static_cast<map::PointId>(i), raw.points[i], 0, {}});
  }
  std::vector<std::vector<map::Observation>> per_keyframe(num_keyframes);
  for (const RawObservation& obs : raw.observations) {
    if (obs.point >= raw.points.size()) {
      fail(path, obs.line, "observation of an unknown point");
    }
    if (obs.frame >= num_keyframes) {
      fail(path, obs.line,
           "observation in pose " + std::to_string(obs.frame) + ", which is not a keyframe");
    }
    const Eigen::Vector2d xy((obs.uv.x() - camera.cx) / camera.fx,
                             (obs.uv.y() - camera.cy) / camera.fy);
    per_keyframe[obs.frame].push_back({static_cast<map::PointId>(obs.point), xy});
  }
  for (std::size_t i = 0; i < num_keyframes; ++i) {
    map::Keyframe keyframe;
    keyframe.id = static_cast<map::KeyframeId>(i);
    keyframe.timestamp = static_cast<double>(i);
    keyframe.T_kf_world = raw.poses[i];
    keyframe.observations = std::move(per_keyframe[i]);
    keble.map.addKeyframe(std::move(keyframe));
  }
  for (auto& entry : keble.map.points()) {
    const auto& observers = entry.second.observed_by;
    if (!observers.empty()) {
      entry.second.reference_keyframe = *std::max_element(observers.begin(), observers.end());
    }
  }
  return keble;
}

}  // namespace scale_drift_slam::io
