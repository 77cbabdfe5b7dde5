#include "scale_drift_slam/ros/node_params.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

#include "scale_drift_slam/io/calibration_io.h"
#include "scale_drift_slam/io/key_suggestion.h"
#include "scale_drift_slam/io/slam_params_io.h"

namespace scale_drift_slam::ros_conversions {
namespace {

using XmlRpc::XmlRpcValue;

std::string kindName(XmlRpcValue::Type type) {
  switch (type) {
    case XmlRpcValue::TypeBoolean:
      return "a bool";
    case XmlRpcValue::TypeInt:
      return "an int";
    case XmlRpcValue::TypeDouble:
      return "a double";
    case XmlRpcValue::TypeString:
      return "a string";
    case XmlRpcValue::TypeStruct:
      return "a namespace";
    case XmlRpcValue::TypeArray:
      return "a list";
    default:
      return "an unsupported kind of value";
  }
}

[[noreturn]] void fail(const std::string& key, const std::string& reason) {
  throw std::runtime_error("parameter ~" + key + ": " + reason);
}

/// Reads `key` into `value` when present; its type must match (an int is taken as a double).
class Reader {
 public:
  explicit Reader(const XmlRpcValue& params) : params_(params) {}

  void read(const std::string& key, std::string* value) {
    if (XmlRpcValue* v = find(key, XmlRpcValue::TypeString, "a string")) {
      *value = static_cast<std::string>(*v);
    }
  }
  void read(const std::string& key, int* value) {
    if (XmlRpcValue* v = find(key, XmlRpcValue::TypeInt, "an int")) *value = static_cast<int>(*v);
  }
  void read(const std::string& key, bool* value) {
    if (XmlRpcValue* v = find(key, XmlRpcValue::TypeBoolean, "a bool")) {
      *value = static_cast<bool>(*v);
    }
  }
  /// A list of numbers (ints taken as doubles) of exactly value->size() entries.
  void read(const std::string& key, std::vector<double>* value) {
    if (XmlRpcValue* v = find(key, XmlRpcValue::TypeArray, "a list")) {
      if (v->size() != static_cast<int>(value->size())) {
        fail(key, "must have " + std::to_string(value->size()) + " numbers, got " +
                      std::to_string(v->size()));
      }
      for (int i = 0; i < v->size(); ++i) {
        XmlRpcValue& x = (*v)[i];
        if (x.getType() == XmlRpcValue::TypeDouble) {
          (*value)[i] = static_cast<double>(x);
        } else if (x.getType() == XmlRpcValue::TypeInt) {
          (*value)[i] = static_cast<int>(x);
        } else {
          fail(key, "must be a list of numbers, got " + kindName(x.getType()));
        }
      }
    }
  }
  /// A path, or a bool: true gives "true", false "".
  void readPathOrBool(const std::string& key, std::string* value) {
    known_.insert(key);
    if (!params_.hasMember(key)) return;
    try {
      *value = pathOrBool(params_[key]);
    } catch (const std::runtime_error&) {
      fail(key, "must be a path or a bool, got " + kindName(params_[key].getType()));
    }
  }
  void read(const std::string& key, double* value) {
    known_.insert(key);
    if (!params_.hasMember(key)) return;
    XmlRpcValue& v = params_[key];
    if (v.getType() == XmlRpcValue::TypeDouble) {
      *value = static_cast<double>(v);
    } else if (v.getType() == XmlRpcValue::TypeInt) {
      *value = static_cast<int>(v);
    } else {
      fail(key, "must be a number, got " + kindName(v.getType()));
    }
  }
  /// Names of the private namespace that were neither read nor are SLAM sections, each with
  /// " (did you mean '~x'?)" when it is close to one that is.
  std::vector<std::string> unknown(const std::set<std::string>& sections) {
    std::vector<std::string> accepted(known_.begin(), known_.end());
    accepted.insert(accepted.end(), sections.begin(), sections.end());
    std::vector<std::string> names;
    for (auto it = params_.begin(); it != params_.end(); ++it) {
      if (known_.count(it->first) || sections.count(it->first)) continue;
      const std::string suggestion = io::closestKey(it->first, accepted);
      names.push_back("~" + it->first +
                      (suggestion.empty() ? "" : " (did you mean '~" + suggestion + "'?)"));
    }
    return names;
  }

 private:
  XmlRpcValue* find(const std::string& key, XmlRpcValue::Type type, const std::string& kind) {
    known_.insert(key);
    if (!params_.hasMember(key)) return nullptr;
    XmlRpcValue& v = params_[key];
    if (v.getType() != type) fail(key, "must be " + kind + ", got " + kindName(v.getType()));
    return &v;
  }

  XmlRpcValue params_;  // a copy: XmlRpcValue's accessors are not const
  std::set<std::string> known_;
};

/// The section of the SLAM parameter file with place recognition's own nested layout
/// (config/place_recognition.yaml): not printed by formatSlamParams.
const char* const kPlaceRecognition = "place_recognition";

/// The sections of the SLAM parameter file (tracker, features, ..., window_ba, mapper, loop_*,
/// system, place_recognition).
std::set<std::string> slamSections() {
  std::set<std::string> sections = {kPlaceRecognition};
  const system::SlamParams default_params;  // a named object: no maybe-uninitialized warning
  const YAML::Node defaults = YAML::Load(io::formatSlamParams(default_params));
  for (const auto& entry : defaults)
    sections.insert(entry.first.as<std::string>());
  return sections;
}

std::string yamlScalar(const std::string& key, XmlRpcValue& v) {
  switch (v.getType()) {
    case XmlRpcValue::TypeBoolean:
      return static_cast<bool>(v) ? "true" : "false";
    case XmlRpcValue::TypeInt:
      return std::to_string(static_cast<int>(v));
    case XmlRpcValue::TypeDouble: {
      char text[64];
      std::snprintf(text, sizeof(text), "%.17g", static_cast<double>(v));
      return text;
    }
    case XmlRpcValue::TypeString:
      return static_cast<std::string>(v);
    default:
      fail(key, "must be a single value, got " + kindName(v.getType()));
  }
}

/// Writes the overrides of namespace `values` (~`path`) into `node`; namespaces inside it are
/// followed only where the file's layout nests (place_recognition), single values elsewhere.
bool mergeOverrides(const std::string& path, XmlRpcValue& values, YAML::Node node, bool nested) {
  bool overridden = false;
  for (auto it = values.begin(); it != values.end(); ++it) {
    const std::string key = path + "/" + it->first;
    if (nested && it->second.getType() == XmlRpcValue::TypeStruct) {
      YAML::Node child = node[it->first];
      if (!child.IsMap()) child = YAML::Node(YAML::NodeType::Map);
      mergeOverrides(key, it->second, child, true);
      node[it->first] = child;
    } else {
      node[it->first] = yamlScalar(key, it->second);
    }
    overridden = true;
  }
  return overridden;
}

std::string readFile(const std::string& key, const std::string& path) {
  std::ifstream file(path);
  if (!file) fail(key, "cannot read '" + path + "'");
  std::stringstream text;
  text << file.rdbuf();
  return text.str();
}

void check(bool ok, const std::string& key, const std::string& reason) {
  if (!ok) fail(key, reason);
}

void readFrames(Reader& reader, FrameNames* frames) {
  reader.read("map_frame", &frames->map);
  reader.read("odom_frame", &frames->odom);
  reader.read("camera_frame", &frames->camera);
  reader.read("optical_frame", &frames->optical);
  reader.read("base_frame", &frames->base);
}

}  // namespace

void TrackingNodeParams::validate() const {
  check(!transport.empty(), "transport", "must not be empty (raw or compressed)");
  check(image_queue_size >= 1, "image_queue_size", "must be >= 1");
  check(keyframe_publish_queue_size >= 1, "keyframe_publish_queue_size", "must be >= 1");
  check(path_publish_every >= 1, "path_publish_every", "must be >= 1");
  check(path_max_poses >= 1, "path_max_poses", "must be >= 1");
  check(std::isfinite(time_jump_restart_s) && time_jump_restart_s >= 0.0, "time_jump_restart_s",
        "must be >= 0");
  check(std::isfinite(rolling_shutter_readout_s) && rolling_shutter_readout_s >= 0.0 &&
            rolling_shutter_readout_s <= 1.0,
        "rolling_shutter_readout_s", "must be in [0, 1] seconds (0: the calibration's)");
  check(std::isfinite(camera_mount_wait_s) && camera_mount_wait_s >= 0.0, "camera_mount_wait_s",
        "must be >= 0");
  check(std::isfinite(odom_tf_timeout_s) && odom_tf_timeout_s >= 0.0, "odom_tf_timeout_s",
        "must be >= 0");
  check(std::isfinite(pose_pixel_sigma_px) && pose_pixel_sigma_px > 0.0, "pose_pixel_sigma_px",
        "must be > 0");
  check(camera_mount.size() == 6, "camera_mount", "must be [x, y, z, roll, pitch, yaw]");
  for (const double x : camera_mount)
    check(std::isfinite(x), "camera_mount", "must be finite numbers");
  check(!localization_only || !map_file.empty(), "localization_only",
        "needs ~map_file (there is no map to localise in)");
  std::vector<std::pair<std::string, std::string>> names = {{"map_frame", frames.map},
                                                            {"odom_frame", frames.odom},
                                                            {"camera_frame", frames.camera},
                                                            {"optical_frame", frames.optical}};
  check(frames.base.empty() || frames.base[0] != '/', "base_frame",
        "must be a frame name without '/' (or empty: no base)");
  if (!frames.base.empty()) names.push_back({"base_frame", frames.base});
  std::set<std::string> distinct;
  for (const auto& [key, name] : names) {
    check(!name.empty() && name[0] != '/', key, "must be a non-empty frame name without '/'");
    check(distinct.insert(name).second, key, "'" + name + "' is used for two frames");
  }
}

void MappingNodeParams::validate() const {
  check(!map_frame.empty() && map_frame[0] != '/', "map_frame",
        "must be a non-empty frame name without '/'");
  check(keyframe_queue_size >= 1, "keyframe_queue_size", "must be >= 1");
  check(std::isfinite(marker_scale) && marker_scale > 0.0, "marker_scale", "must be > 0");
  check(save_map_on_shutdown != "true" || !save_map_file.empty(), "save_map_on_shutdown",
        "is true but ~save_map_file is not set");
}

void LoopClosureNodeParams::validate() const {
  check(keyframe_queue_size >= 1, "keyframe_queue_size", "must be >= 1");
}

system::SlamParams slamParams(const XmlRpc::XmlRpcValue& private_params) {
  XmlRpcValue params = private_params;
  std::string config_file;
  Reader(params).read("config", &config_file);
  const std::string origin = config_file.empty() ? "(defaults)" : "'" + config_file + "'";
  YAML::Node merged;
  try {
    merged = config_file.empty() ? YAML::Node(YAML::NodeType::Map)
                                 : YAML::Load(readFile("config", config_file));
  } catch (const YAML::Exception& e) {
    fail("config", "'" + config_file + "' is not YAML: " + e.what());
  }
  if (!merged.IsMap()) merged = YAML::Node(YAML::NodeType::Map);
  bool overridden = false;
  for (const std::string& section : slamSections()) {
    if (!params.hasMember(section)) continue;
    XmlRpcValue& values = params[section];
    if (values.getType() != XmlRpcValue::TypeStruct) {
      fail(section,
           "must be a namespace of " + section + " parameters, got " + kindName(values.getType()));
    }
    YAML::Node target = merged[section];
    if (!target.IsMap()) target = YAML::Node(YAML::NodeType::Map);
    overridden |= mergeOverrides(section, values, target, section == kPlaceRecognition);
    merged[section] = target;
  }
  try {
    return io::parseSlamParams(YAML::Dump(merged),
                               origin + (overridden ? " with ~<section>/<key> overrides" : ""));
  } catch (const std::exception& e) {
    throw std::runtime_error(std::string("SLAM ") + e.what());
  }
}

TrackingNodeConfig trackingNodeConfig(const XmlRpc::XmlRpcValue& private_params) {
  TrackingNodeConfig config;
  Reader reader(private_params);
  TrackingNodeParams& p = config.node;
  reader.read("config", &p.config_file);
  reader.read("calibration_file", &p.calibration_file);
  reader.read("rolling_shutter_readout_s", &p.rolling_shutter_readout_s);
  reader.read("transport", &p.transport);
  reader.read("image_queue_size", &p.image_queue_size);
  reader.read("keyframe_publish_queue_size", &p.keyframe_publish_queue_size);
  readFrames(reader, &p.frames);
  reader.read("map_z_up", &p.map_z_up);
  reader.read("publish_optical_transform", &p.publish_optical_transform);
  reader.read("publish_tf", &p.publish_tf);
  reader.read("publish_odom_tf", &p.publish_odom_tf);
  reader.read("camera_mount", &p.camera_mount);
  reader.read("camera_mount_wait_s", &p.camera_mount_wait_s);
  reader.read("odom_tf_timeout_s", &p.odom_tf_timeout_s);
  reader.read("pose_pixel_sigma_px", &p.pose_pixel_sigma_px);
  reader.read("path_publish_every", &p.path_publish_every);
  reader.read("path_max_poses", &p.path_max_poses);
  reader.read("time_jump_restart_s", &p.time_jump_restart_s);
  reader.read("map_file", &p.map_file);
  reader.read("localization_only", &p.localization_only);
  p.validate();
  config.slam = slamParams(private_params);
  if (!p.calibration_file.empty()) {
    try {
      config.calibration = io::loadCalibrationYaml(p.calibration_file);
      if (p.rolling_shutter_readout_s > 0.0) {
        config.calibration->rolling_shutter_readout_s = p.rolling_shutter_readout_s;
      }
    } catch (const std::exception& e) {
      fail("calibration_file", e.what());
    }
  }
  config.unknown = reader.unknown(slamSections());
  return config;
}

MappingNodeConfig mappingNodeConfig(const XmlRpc::XmlRpcValue& private_params) {
  MappingNodeConfig config;
  Reader reader(private_params);
  MappingNodeParams& p = config.node;
  reader.read("config", &p.config_file);
  reader.read("map_frame", &p.map_frame);
  reader.read("map_z_up", &p.map_z_up);
  reader.read("trajectory_file", &p.trajectory_file);
  reader.read("keyframe_queue_size", &p.keyframe_queue_size);
  reader.read("marker_scale", &p.marker_scale);
  reader.read("map_file", &p.map_file);
  reader.read("save_map_file", &p.save_map_file);
  reader.readPathOrBool("save_map_on_shutdown", &p.save_map_on_shutdown);
  p.validate();
  config.slam = slamParams(private_params);
  config.unknown = reader.unknown(slamSections());
  return config;
}

LoopClosureNodeConfig loopClosureNodeConfig(const XmlRpc::XmlRpcValue& private_params) {
  LoopClosureNodeConfig config;
  Reader reader(private_params);
  LoopClosureNodeParams& p = config.node;
  reader.read("config", &p.config_file);
  reader.read("keyframe_queue_size", &p.keyframe_queue_size);
  reader.read("map_file", &p.map_file);
  p.validate();
  config.slam = slamParams(private_params);
  config.unknown = reader.unknown(slamSections());
  return config;
}

std::string pathOrBool(const XmlRpc::XmlRpcValue& value) {
  XmlRpcValue v = value;  // XmlRpcValue's conversions are not const
  if (v.getType() == XmlRpcValue::TypeBoolean) return static_cast<bool>(v) ? "true" : "";
  if (v.getType() != XmlRpcValue::TypeString) throw std::runtime_error("not a path or a bool");
  const std::string text = static_cast<std::string>(v);
  return text == "false" ? "" : text;
}

XmlRpc::XmlRpcValue privateParams(const ros::NodeHandle& private_nh) {
  XmlRpcValue params;
  if (!private_nh.getParam(private_nh.getNamespace(), params) ||
      params.getType() != XmlRpcValue::TypeStruct) {
    params = XmlRpcValue();
    params.begin();  // an empty struct
  }
  return params;
}

std::string describe(const TrackingNodeConfig& c) {
  const TrackingNodeParams& p = c.node;
  std::ostringstream out;
  out << "config: " << (p.config_file.empty() ? "(defaults)" : p.config_file) << "\n"
      << "calibration_file: "
      << (p.calibration_file.empty() ? "(none: CameraInfo)" : p.calibration_file) << "\n";
  if (c.calibration) out << "camera: " << c.calibration->describe() << "\n";
  out << "transport: " << p.transport << "\nimage_queue_size: " << p.image_queue_size
      << "\nkeyframe_publish_queue_size: " << p.keyframe_publish_queue_size << "\nframes: map "
      << p.frames.map << ", odom " << p.frames.odom << ", camera " << p.frames.camera
      << ", optical " << p.frames.optical << ", base "
      << (p.frames.base.empty() ? "(none)" : p.frames.base) << "\nmap_z_up: " << p.map_z_up
      << "\npublish_optical_transform: " << p.publish_optical_transform
      << "\npublish_tf: " << p.publish_tf << "\npublish_odom_tf: " << p.publish_odom_tf
      << "\ncamera_mount: [" << p.camera_mount[0] << ", " << p.camera_mount[1] << ", "
      << p.camera_mount[2] << ", " << p.camera_mount[3] << ", " << p.camera_mount[4] << ", "
      << p.camera_mount[5] << "] (used only when tf has none)"
      << "\ncamera_mount_wait_s: " << p.camera_mount_wait_s
      << "\nodom_tf_timeout_s: " << p.odom_tf_timeout_s
      << "\npose_pixel_sigma_px: " << p.pose_pixel_sigma_px
      << "\npath_publish_every: " << p.path_publish_every
      << "\npath_max_poses: " << p.path_max_poses
      << "\ntime_jump_restart_s: " << p.time_jump_restart_s
      << "\nrolling_shutter_readout_s: " << p.rolling_shutter_readout_s
      << "\nmap_file: " << (p.map_file.empty() ? "(none: a new map)" : p.map_file)
      << "\nlocalization_only: " << p.localization_only << "\n# SLAM parameters\n"
      << io::formatSlamParams(c.slam);
  return out.str();
}

std::string describe(const MappingNodeConfig& c) {
  const MappingNodeParams& p = c.node;
  std::ostringstream out;
  out << "config: " << (p.config_file.empty() ? "(defaults)" : p.config_file)
      << "\nmap_frame: " << p.map_frame << "\nmap_z_up: " << p.map_z_up
      << "\ntrajectory_file: " << (p.trajectory_file.empty() ? "(none)" : p.trajectory_file)
      << "\nkeyframe_queue_size: " << p.keyframe_queue_size << "\nmarker_scale: " << p.marker_scale
      << "\nmap_file: " << (p.map_file.empty() ? "(none: a new map)" : p.map_file)
      << "\nsave_map_file: " << (p.save_map_file.empty() ? "(none)" : p.save_map_file)
      << "\nsave_map_on_shutdown: "
      << (p.save_map_on_shutdown.empty() ? "(no)" : p.save_map_on_shutdown)
      << "\n# SLAM parameters\n"
      << io::formatSlamParams(c.slam);
  return out.str();
}

std::string describe(const LoopClosureNodeConfig& c) {
  const loop::LoopCloserParams& loop = c.slam.loop;
  const loop::PlaceRecognitionParams& r = loop.recognition;
  std::ostringstream out;
  out << "config: " << (c.node.config_file.empty() ? "(defaults)" : c.node.config_file)
      << "\nkeyframe_queue_size: " << c.node.keyframe_queue_size
      << "\nmap_file: " << (c.node.map_file.empty() ? "(none: a new map)" : c.node.map_file)
      << "\n# SLAM parameters\n";
  // The loop closer's sections of the whole file; place recognition in short.
  const YAML::Node all = YAML::Load(io::formatSlamParams(c.slam));
  for (const char* section : {"loop_closure", "loop_verification"}) {
    YAML::Node only;
    only[section] = all[section];
    out << YAML::Dump(only) << "\n";
  }
  out << "place_recognition: ORB " << r.appearance.max_features << " features, vocabulary "
      << (r.vocabulary_file.empty() ? "learned from the first " +
                                          std::to_string(r.online_training_keyframes) + " keyframes"
                                    : r.vocabulary_file)
      << ", newest " << r.recent_keyframes_excluded << " keyframes excluded, "
      << r.min_consistent_queries << " consistent queries, geometric check "
      << r.geometry.min_inliers << " inliers\n";
  return out.str();
}

}  // namespace scale_drift_slam::ros_conversions
