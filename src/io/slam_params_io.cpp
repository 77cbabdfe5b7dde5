#include "scale_drift_slam/io/slam_params_io.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <variant>

#include <yaml-cpp/yaml.h>

#include "scale_drift_slam/io/key_suggestion.h"
#include "scale_drift_slam/io/place_recognition_params_io.h"

namespace scale_drift_slam::io {
namespace {

using system::SlamParams;

/// A named parameter: where it lives in the struct and how to read/print it.
struct Field {
  std::string section, key;
  std::variant<int*, double*, bool*> value;
  /// For enums kept as text: the parser and the printer.
  std::function<void(const std::string&)> parse_text = nullptr;
  std::function<std::string()> print_text = nullptr;
};

std::vector<Field> fieldsOf(system::SlamParams& p) {
  auto& t = p.tracker;
  auto& l = p.loop;
  auto& v = p.loop.verification;
  auto& c = p.mapper.loop_correction;
  std::vector<Field> f = {
      {"tracker", "pyramid_levels", &t.pyramid_levels},
      {"tracker", "min_contrast", &t.min_contrast},
      {"tracker", "contrast_target_range", &t.contrast_target_range},
      {"tracker", "max_contrast_gain", &t.max_contrast_gain},
      {"tracker", "mono16_bit_depth", &t.mono16_bit_depth},
      {"tracker", "good_inliers", &t.good_inliers},
      {"tracker", "min_inliers", &t.min_inliers},
      {"tracker", "local_recent_keyframes", &t.local_recent_keyframes},
      {"tracker", "local_nearest_keyframes", &t.local_nearest_keyframes},
      {"tracker", "local_covisibility_min_shared", &t.local_covisibility_min_shared},
      {"tracker", "retire_after_searches", &t.retire_after_searches},
      {"tracker", "retire_found_ratio", &t.retire_found_ratio},
      {"tracker", "max_rejected_frames", &t.max_rejected_frames},
      {"tracker", "relocalisation_retry_frames", &t.relocalisation_retry_frames},
      {"tracker", "restart_after_lost_frames", &t.restart_after_lost_frames},
      {"tracker", "restart_below_keyframes", &t.restart_below_keyframes},
      {"tracker", "recover_from_keyframe", &t.recover_from_keyframe},
      {"tracker", "recover_on_inlier_share_drop", &t.recover_on_inlier_share_drop},
      {"tracker", "recover_on_inlier_drop", &t.recover_on_inlier_drop},
      {"tracker", "recovery_max_descriptor_distance", &t.recovery_max_descriptor_distance},
      {"tracker", "recovery_max_ratio", &t.recovery_max_ratio},
      {"tracker", "keyframe_refused_matches_px", &t.keyframe_refused_matches_px},
      {"tracker", "compress_idle_patches_after_frames", &t.compress_idle_patches_after_frames},
      {"tracker", "keyframe_worker", &t.keyframe_worker},
      {"features", "fast_threshold", &t.features.fast_threshold},
      {"features", "min_fast_threshold", &t.features.min_fast_threshold},
      {"features", "border", &t.features.border},
      {"features", "min_distance", &t.features.min_distance},
      {"initializer", "num_features", &t.initializer.num_features},
      {"initializer", "min_tracks", &t.initializer.min_tracks},
      {"initializer", "min_disparity_px", &t.initializer.min_disparity_px},
      {"initializer", "max_frames", &t.initializer.max_frames},
      {"initializer", "ransac_threshold_px", &t.initializer.two_view.ransac_threshold_px},
      {"initializer", "sigma_px", &t.initializer.two_view.sigma_px},
      {"initializer", "max_reprojection_px", &t.initializer.two_view.max_reprojection_px},
      {"initializer", "min_point_parallax_deg", &t.initializer.two_view.min_point_parallax_deg},
      {"initializer", "min_median_parallax_deg", &t.initializer.two_view.min_median_parallax_deg},
      {"initializer", "min_points", &t.initializer.two_view.min_points},
      {"initializer", "min_good_fraction", &t.initializer.two_view.min_good_fraction},
      {"initializer", "ambiguity_ratio", &t.initializer.two_view.ambiguity_ratio},
      {"initializer", "ambiguity_sigmas", &t.initializer.two_view.ambiguity_sigmas},
      {"initializer", "max_rotation_sigma_ratio", &t.initializer.two_view.max_rotation_sigma_ratio},
      {"initializer", "bundle_adjustment_iterations",
       &t.initializer.two_view.bundle_adjustment_iterations},
      {"flow", "window", &t.motion_prior.flow.window},
      {"flow", "pyramid_levels", &t.motion_prior.flow.pyramid_levels},
      {"flow", "max_iterations", &t.motion_prior.flow.max_iterations},
      {"flow", "min_step_px", &t.motion_prior.flow.min_step_px},
      {"flow", "max_error", &t.motion_prior.flow.max_error},
      {"flow", "max_forward_backward_px", &t.motion_prior.flow.max_forward_backward_px},
      {"flow", "dis_preset", &t.motion_prior.flow.dis_preset},
      {"flow", "photometric_radius", &t.motion_prior.flow.photometric_radius},
      {"flow", "shift_retry_px", &t.motion_prior.flow.shift_retry_px},
      {"motion_prior", "flow_sigma_px", &t.motion_prior.flow_sigma_px},
      {"motion_prior", "predict_flow", &t.motion_prior.predict_flow},
      {"motion_prior", "candidate_max_forward_backward_px",
       &t.motion_prior.candidate_max_forward_backward_px},
      {"motion_prior", "candidate_flow_window", &t.motion_prior.candidate_flow_window},
      {"motion_prior", "min_tracks", &t.motion_prior.min_tracks},
      {"motion_prior", "max_tracks", &t.motion_prior.max_tracks},
      {"motion_prior", "min_rotation_sigma", &t.motion_prior.min_rotation_sigma},
      {"motion_prior", "min_translation_sigma", &t.motion_prior.min_translation_sigma},
      {"motion_prior", "fallback_rotation_sigma", &t.motion_prior.fallback_rotation_sigma},
      {"motion_prior", "fallback_translation_sigma", &t.motion_prior.fallback_translation_sigma},
      {"search", "template_radius", &t.search.template_radius},
      {"search", "min_ncc", &t.search.min_ncc},
      {"search", "gate_chi2", &t.search.gate_chi2},
      {"search", "pixel_sigma_px", &t.search.pixel_sigma_px},
      {"search", "min_radius_px", &t.search.min_radius_px},
      {"search", "max_radius_px", &t.search.max_radius_px},
      {"search", "fast_threshold", &t.search.fast_threshold},
      {"search", "max_scale_change", &t.search.max_scale_change},
      {"search", "max_view_angle_deg", &t.search.max_view_angle_deg},
      {"search", "max_points", &t.search.max_points},
      {"search", "min_coarse_corner_density", &t.search.min_coarse_corner_density},
      {"motion_ba", "huber_width_px", &t.motion_ba.huber_width_px},
      {"motion_ba", "inlier_threshold_px", &t.motion_ba.inlier_threshold_px},
      {"motion_ba", "max_iterations", &t.motion_ba.max_iterations},
      {"motion_ba", "min_step_norm", &t.motion_ba.min_step_norm},
      {"motion_ba", "function_tolerance", &t.motion_ba.function_tolerance},
      {"candidates", "max_candidates", &t.candidates.max_candidates},
      {"candidates", "new_per_keyframe", &t.candidates.new_per_keyframe},
      {"candidates", "max_rejections", &t.candidates.max_rejections},
      {"candidates", "max_views", &t.candidates.max_views},
      {"filter", "pixel_sigma_px", &t.candidates.filter.pixel_sigma_px},
      {"filter", "min_parallax_deg", &t.candidates.filter.min_parallax_deg},
      {"filter", "max_residual_sigmas", &t.candidates.filter.max_residual_sigmas},
      {"filter", "max_iterations", &t.candidates.filter.max_iterations},
      {"filter", "max_relative_depth_sigma", &t.candidates.filter.max_relative_depth_sigma},
      {"filter", "min_updates", &t.candidates.filter.min_updates},
      {"filter", "max_promotion_error_px", &t.candidates.filter.max_promotion_error_px},
      {"triangulation", "max_features", &t.triangulation.max_features},
      {"triangulation", "neighbours", &t.triangulation.neighbours},
      {"triangulation", "max_descriptor_distance", &t.triangulation.max_descriptor_distance},
      {"triangulation", "max_ratio", &t.triangulation.max_ratio},
      {"triangulation", "max_epipolar_px", &t.triangulation.max_epipolar_px},
      {"triangulation", "min_parallax_deg", &t.triangulation.min_parallax_deg},
      {"triangulation", "max_reprojection_px", &t.triangulation.max_reprojection_px},
      {"keyframes", "distance_to_depth_ratio", &t.keyframes.distance_to_depth_ratio},
      {"keyframes", "max_distance_to_depth_ratio", &t.keyframes.max_distance_to_depth_ratio},
      {"keyframes", "min_tracked_ratio", &t.keyframes.min_tracked_ratio},
      {"keyframes", "min_tracked_points", &t.keyframes.min_tracked_points},
      {"keyframes", "min_distance_fraction", &t.keyframes.min_distance_fraction},
      {"keyframes", "min_certain_candidates", &t.keyframes.min_certain_candidates},
      {"keyframes", "max_view_turn_fraction", &t.keyframes.max_view_turn_fraction},
      {"window_ba", "window_size", &p.mapper.window.window_size},
      {"window_ba", "num_fixed_keyframes", &p.mapper.window.num_fixed_keyframes},
      {"window_ba", "huber_width_px", &p.mapper.window.huber_width_px},
      {"window_ba", "inlier_threshold_px", &p.mapper.window.inlier_threshold_px},
      {"window_ba", "max_iterations", &p.mapper.window.max_iterations},
      {"window_ba", "function_tolerance", &p.mapper.window.function_tolerance},
      {"window_ba", "num_threads", &p.mapper.window.num_threads},
      {"mapper", "run_window_ba", &p.mapper.run_window_ba},
      {"point_culling", "min_keyframes", &p.mapper.point_culling.min_keyframes},
      {"point_culling", "after_keyframes", &p.mapper.point_culling.after_keyframes},
      {"keyframe_culling", "redundant_ratio", &p.mapper.keyframe_culling.redundant_ratio},
      {"keyframe_culling", "min_other_observers", &p.mapper.keyframe_culling.min_other_observers},
      {"loop_closure", "enabled", &l.enabled},
      {"loop_closure", "covisible_min_shared_points", &l.covisible_min_shared_points},
      {"loop_closure", "relocalisation_candidates", &l.relocalisation_candidates},
      {"loop_closure", "image_jpeg_quality", &l.image_jpeg_quality},
      {"loop_closure", "relocalisation_min_inliers", &l.relocalisation_geometry.min_inliers},
      {"loop_closure", "relocalisation_min_coverage", &l.relocalisation_geometry.min_coverage},
      {"loop_verification", "depth_neighbours", &v.depth.k},
      {"loop_verification", "depth_min_neighbours", &v.depth.min_neighbours},
      {"loop_verification", "depth_max_distance_px", &v.depth.max_distance_px},
      {"loop_verification", "depth_max_relative_spread", &v.depth.max_relative_spread},
      {"loop_verification", "ransac_threshold_px", &v.constraint.ransac_threshold_px},
      {"loop_verification", "ransac_iterations", &v.constraint.ransac_iterations},
      {"loop_verification", "min_inliers", &v.constraint.min_inliers},
      {"loop_verification", "min_inlier_ratio", &v.constraint.min_inlier_ratio},
      {"loop_verification", "min_scale_pairs", &v.constraint.min_scale_pairs},
      {"loop_verification", "search_rotation_sigma", &v.search_rotation_sigma},
      {"loop_verification", "search_translation_sigma", &v.search_translation_sigma},
      {"loop_verification", "min_final_inliers", &v.min_final_inliers},
      {"loop_verification", "max_rmse_px", &v.max_rmse_px},
      {"loop_verification", "min_scale", &v.min_scale},
      {"loop_verification", "max_scale", &v.max_scale},
      {"loop_correction", "max_iterations", &c.graph.max_iterations},
      {"loop_correction", "function_tolerance", &c.graph.function_tolerance},
      {"loop_correction", "loop_error_passes", &c.graph.loop_error_passes},
      {"loop_correction", "initial_damping", &c.graph.initial_damping},
      {"loop_correction", "covisibility_min_shared_points", &c.covisibility_min_shared_points},
      {"loop_correction", "covisibility_max_edges", &c.covisibility_max_edges},
      {"loop_correction", "loop_edge_weight", &c.loop_edge_weight},
      {"loop_correction", "structure_iterations", &c.structure.max_iterations},
      {"loop_correction", "structure_huber_width_px", &c.structure.huber_width_px},
      {"loop_correction", "structure_min_shift_px", &c.structure_min_shift_px},
      {"system", "mapping_thread", &p.mapping_thread},
      {"messages", "max_observations", &p.messages.max_observations},
      {"messages", "max_new_points", &p.messages.max_new_points},
      {"messages", "max_keyframe_id_gap", &p.messages.max_keyframe_id_gap},
      {"messages", "max_update_entries", &p.messages.max_update_entries},
      {"messages", "max_found_points", &p.messages.max_found_points},
      {"messages", "max_image_side", &p.messages.max_image_side},
      {"messages", "max_coordinate", &p.messages.max_coordinate},
      {"messages", "max_normalised", &p.messages.max_normalised},
      {"messages", "max_scale_ratio", &p.messages.max_scale_ratio},
  };
  Field flow_method{"flow", "method", static_cast<int*>(nullptr)};
  flow_method.parse_text = [&t](const std::string& s) {
    t.motion_prior.flow.method = tracking::parseFlowMethod(s);
  };
  flow_method.print_text = [&t] { return tracking::flowMethodName(t.motion_prior.flow.method); };
  f.insert(
      std::find_if(f.begin(), f.end(), [](const Field& field) { return field.section == "flow"; }),
      flow_method);
  Field graph_mode{"loop_correction", "mode", static_cast<int*>(nullptr)};
  graph_mode.parse_text = [&c](const std::string& s) {
    c.graph.mode = loop::parsePoseGraphMode(s);
  };
  graph_mode.print_text = [&c] { return loop::toString(c.graph.mode); };
  f.insert(std::find_if(f.begin(), f.end(),
                        [](const Field& field) { return field.section == "loop_correction"; }),
           graph_mode);
  Field solver{"motion_ba", "solver", static_cast<int*>(nullptr)};
  solver.parse_text = [&t](const std::string& s) {
    if (s == "hand_written") {
      t.motion_ba.solver = features::MotionOnlySolver::kHandWritten;
    } else if (s == "ceres") {
      t.motion_ba.solver = features::MotionOnlySolver::kCeres;
    } else {
      throw std::invalid_argument("unknown solver '" + s + "' (accepted: hand_written, ceres)");
    }
  };
  solver.print_text = [&t] {
    return std::string(t.motion_ba.solver == features::MotionOnlySolver::kCeres ? "ceres"
                                                                                : "hand_written");
  };
  const auto candidates_section = std::find_if(
      f.begin(), f.end(), [](const Field& field) { return field.section == "candidates"; });
  f.insert(candidates_section, solver);
  return f;
}

[[noreturn]] void fail(const std::string& origin, const std::string& reason) {
  throw std::runtime_error("parameters " + origin + ": " + reason);
}

void readField(const Field& field, const YAML::Node& node, const std::string& origin) {
  const std::string name = field.section + "." + field.key;
  try {
    if (field.parse_text) {
      field.parse_text(node.as<std::string>());
    } else if (auto* i = std::get_if<int*>(&field.value)) {
      **i = node.as<int>();
    } else if (auto* d = std::get_if<double*>(&field.value)) {
      const double value = node.as<double>();
      if (!std::isfinite(value)) fail(origin, "'" + name + "' must be a finite number");
      **d = value;
    } else if (auto* b = std::get_if<bool*>(&field.value)) {
      **b = node.as<bool>();
    }
  } catch (const YAML::Exception&) {
    fail(origin, "'" + name + "' does not hold the expected kind of value");
  } catch (const std::invalid_argument& e) {
    fail(origin, "'" + name + "': " + e.what());
  }
}

/// "unknown key 'section.key'" with the closest key of the file, or the section that has it.
std::string unknownKey(const std::string& section, const std::string& key,
                       const std::map<std::string, std::set<std::string>>& known) {
  std::vector<std::string> keys;
  for (const auto& [other, other_keys] : known) {
    for (const std::string& other_key : other_keys)
      keys.push_back(other + "." + other_key);
  }
  const std::string name = section + "." + key;
  if (!closestKey(name, keys).empty()) return unknownKeyMessage("key", name, keys);
  for (const auto& [other, other_keys] : known) {  // the right key in the wrong section
    if (other_keys.count(key)) return unknownKeyMessageSuggesting("key", name, other + "." + key);
  }
  return unknownKeyMessage("key", name, keys);
}

}  // namespace

system::SlamParams parseSlamParams(const std::string& text, const std::string& origin) {
  system::SlamParams params;
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    fail(origin, std::string("not valid YAML (") + e.what() + ")");
  }
  if (root.IsNull()) return params;
  if (!root.IsMap()) fail(origin, "expected a mapping of sections (tracker, search, ...)");
  const std::vector<Field> fields = fieldsOf(params);
  std::map<std::string, std::set<std::string>> known;
  for (const Field& field : fields)
    known[field.section].insert(field.key);
  std::vector<std::string> sections = {"place_recognition"};
  for (const auto& entry : known)
    sections.push_back(entry.first);
  for (const auto& section : root) {
    if (!section.first.IsScalar()) fail(origin, "a section name is not text");
    const std::string name = section.first.Scalar();
    if (name == "place_recognition") {
      // Its own loader (io/place_recognition_params_io.h) and layout
      // (config/place_recognition.yaml).
      params.loop.recognition =
          parsePlaceRecognitionParams(YAML::Dump(section.second), origin + " place_recognition");
      continue;
    }
    if (!known.count(name)) fail(origin, unknownKeyMessage("section", name, sections));
    if (!section.second.IsMap()) fail(origin, "section '" + name + "' must be a mapping");
    for (const auto& entry : section.second) {
      if (!entry.first.IsScalar())
        fail(origin, "section '" + name + "' holds a key that is not a name");
      const std::string key = entry.first.Scalar();
      if (!known[name].count(key)) fail(origin, unknownKey(name, key, known));
    }
  }
  for (const Field& field : fields) {
    const YAML::Node section = root[field.section];
    if (section && section[field.key]) readField(field, section[field.key], origin);
  }
  try {
    params.validate();
  } catch (const std::invalid_argument& e) {
    fail(origin, e.what());
  }
  return params;
}

system::SlamParams loadSlamParams(const std::string& path) {
  std::ifstream file(path);
  if (!file) fail("'" + path + "'", "cannot open the file");
  std::stringstream text;
  text << file.rdbuf();
  return parseSlamParams(text.str(), "'" + path + "'");
}

std::string formatSlamParams(const system::SlamParams& params_in) {
  system::SlamParams params = params_in;
  std::ostringstream out;
  out.precision(10);
  std::string section;
  for (const Field& field : fieldsOf(params)) {
    if (field.section != section) {
      section = field.section;
      out << section << ":\n";
    }
    out << "  " << field.key << ": ";
    if (field.print_text) {
      out << field.print_text();
    } else if (auto* i = std::get_if<int*>(&field.value)) {
      out << **i;
    } else if (auto* d = std::get_if<double*>(&field.value)) {
      out << **d;
    } else if (auto* b = std::get_if<bool*>(&field.value)) {
      out << (**b ? "true" : "false");
    }
    out << "\n";
  }
  return out.str();
}

}  // namespace scale_drift_slam::io
