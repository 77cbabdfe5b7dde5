#pragma once
// The SLAM's parameters as YAML: one place that reads, validates and prints every module's typed
// parameter struct (tracking, mapping). The file is sectioned by module (tracker, features,
// initializer, flow, motion_prior, search, motion_ba, candidates, filter, keyframes, window_ba,
// mapper, system); config/default.yaml lists every key with its default and meaning. Keys left
// out keep their defaults; an unknown key or a bad value is an error naming the file and the key.

#include <string>

#include "scale_drift_slam/system/slam_params.h"

namespace scale_drift_slam::io {

/// Reads and validates a parameter file. Throws std::runtime_error naming the file and the
/// problem (unreadable, not YAML, unknown key, wrong kind of value, invalid value).
system::SlamParams loadSlamParams(const std::string& path);
/// The same from YAML text; `origin` names the source in error messages. Empty text = defaults.
system::SlamParams parseSlamParams(const std::string& text, const std::string& origin = "<string>");
/// Every parameter as YAML in the file's layout (printed once at start-up; loadable again).
std::string formatSlamParams(const system::SlamParams& params);

}  // namespace scale_drift_slam::io
