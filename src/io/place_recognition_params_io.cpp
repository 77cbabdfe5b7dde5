#include "scale_drift_slam/io/place_recognition_params_io.h"

#include <cmath>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <stdexcept>
#include <type_traits>

#include <yaml-cpp/yaml.h>

#include "scale_drift_slam/io/key_suggestion.h"

namespace scale_drift_slam::io {
namespace {

using Setter = std::function<void(const YAML::Node&)>;

[[noreturn]] void fail(const std::string& origin, const std::string& reason) {
  throw std::runtime_error("place recognition params " + origin + ": " + reason);
}

template <typename T>
Setter set(T& field) {
  return [&field](const YAML::Node& node) {
    const T value = node.as<T>();
    if constexpr (std::is_floating_point_v<T>) {
      if (!std::isfinite(value)) throw std::domain_error("not a finite number");
    }
    field = value;
  };
}

/// Applies every key of `section` through its setter; unknown keys and wrong kinds fail.
void apply(const YAML::Node& section, const std::string& prefix,
           const std::map<std::string, Setter>& setters, const std::string& origin) {
  if (!section.IsMap()) fail(origin, "'" + prefix + "' must be a mapping of keys");
  for (const auto& entry : section) {
    if (!entry.first.IsScalar()) fail(origin, "'" + prefix + "' holds a key that is not a name");
    const std::string key = entry.first.Scalar();
    const auto setter = setters.find(key);
    const std::string name = prefix + key;
    if (setter == setters.end()) {
      std::vector<std::string> names;
      for (const auto& [known, unused] : setters)
        names.push_back(prefix + known);
      fail(origin, unknownKeyMessage("key", name, names));
    }
    try {
      setter->second(entry.second);
    } catch (const YAML::Exception&) {
      fail(origin, "key '" + name + "' does not hold the expected kind of value");
    } catch (const std::domain_error& e) {
      fail(origin, "key '" + name + "' is " + e.what());
    }
  }
}

loop::PlaceRecognitionParams parseRoot(const YAML::Node& root, const std::string& origin) {
  loop::PlaceRecognitionParams p;
  loop::AppearanceParams& a = p.appearance;
  loop::VocabularyParams& v = p.vocabulary;
  loop::GeometricCheckParams& g = p.geometry;
  const std::map<std::string, Setter> appearance = {
      {"max_features", set(a.max_features)},
      {"grid_cols", set(a.grid_cols)},
      {"grid_rows", set(a.grid_rows)},
      {"pyramid_levels", set(a.pyramid_levels)},
      {"scale_factor", set(a.scale_factor)},
      {"fast_threshold", set(a.fast_threshold)},
      {"min_fast_threshold", set(a.min_fast_threshold)},
      {"border", set(a.border)}};
  const std::map<std::string, Setter> vocabulary = {
      {"branching", set(v.branching)},
      {"depth", set(v.depth)},
      {"max_iterations", set(v.max_iterations)},
      {"max_training_descriptors", set(v.max_training_descriptors)},
      {"seed", set(v.seed)}};
  const std::map<std::string, Setter> geometry = {
      {"max_hamming", set(g.max_hamming)},
      {"ratio", set(g.ratio)},
      {"group_levels_up", set(g.group_levels_up)},
      {"ransac_threshold_px", set(g.ransac_threshold_px)},
      {"ransac_confidence", set(g.ransac_confidence)},
      {"ransac_max_iterations", set(g.ransac_max_iterations)},
      {"min_inliers", set(g.min_inliers)},
      {"min_inlier_ratio", set(g.min_inlier_ratio)},
      {"coverage_cols", set(g.coverage_cols)},
      {"coverage_rows", set(g.coverage_rows)},
      {"min_features_per_cell", set(g.min_features_per_cell)},
      {"min_inliers_per_cell", set(g.min_inliers_per_cell)},
      {"min_coverage", set(g.min_coverage)},
      {"max_scale_change", set(g.max_scale_change)}};
  const std::map<std::string, Setter> top = {
      {"appearance", [&](const YAML::Node& n) { apply(n, "appearance.", appearance, origin); }},
      {"vocabulary", [&](const YAML::Node& n) { apply(n, "vocabulary.", vocabulary, origin); }},
      {"geometry", [&](const YAML::Node& n) { apply(n, "geometry.", geometry, origin); }},
      {"vocabulary_file", set(p.vocabulary_file)},
      {"online_training_keyframes", set(p.online_training_keyframes)},
      {"recent_keyframes_excluded", set(p.recent_keyframes_excluded)},
      {"recent_seconds_excluded", set(p.recent_seconds_excluded)},
      {"min_reference_score", set(p.min_reference_score)},
      {"min_normalized_score", set(p.min_normalized_score)},
      {"island_gap", set(p.island_gap)},
      {"max_islands_checked", set(p.max_islands_checked)},
      {"min_consistent_queries", set(p.min_consistent_queries)},
      {"consistency_gap", set(p.consistency_gap)},
      {"consistency_max_missed", set(p.consistency_max_missed)},
      {"suppress_loop_continuation", set(p.suppress_loop_continuation)},
      {"continuation_gap", set(p.continuation_gap)}};
  apply(root, "", top, origin);
  try {
    p.validate();
  } catch (const std::invalid_argument& e) {
    fail(origin, e.what());
  }
  return p;
}

}  // namespace

loop::PlaceRecognitionParams parsePlaceRecognitionParams(const std::string& text,
                                                         const std::string& origin) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    fail(origin, std::string("not valid YAML (") + e.what() + ")");
  }
  if (root.IsNull()) return parseRoot(YAML::Node(YAML::NodeType::Map), origin);
  if (root.IsMap() && root["place_recognition"]) root = root["place_recognition"];
  return parseRoot(root, origin);
}

loop::PlaceRecognitionParams loadPlaceRecognitionParams(const std::string& path) {
  std::ifstream file(path);
  if (!file) fail(path, "cannot open");
  std::stringstream text;
  text << file.rdbuf();
  loop::PlaceRecognitionParams params = parsePlaceRecognitionParams(text.str(), path);
  const std::string& vocabulary = params.vocabulary_file;
  if (!vocabulary.empty() && vocabulary.front() != '/') {
    const std::size_t slash = path.find_last_of('/');
    if (slash != std::string::npos) params.vocabulary_file = path.substr(0, slash + 1) + vocabulary;
  }
  return params;
}

}  // namespace scale_drift_slam::io
