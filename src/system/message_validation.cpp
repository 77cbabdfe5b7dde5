#include "scale_drift_slam/system/message_validation.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace scale_drift_slam::system {
namespace {

std::string number(double value) {
  std::ostringstream s;
  s << value;
  return s.str();
}

std::string poseProblem(const geometry::SE3& pose, const MessageLimits& limits) {
  if (!pose.rotation().coeffs().allFinite() || !pose.translation().allFinite())
    return "a non-finite pose";
  const double norm = pose.translation().norm();
  if (norm > limits.max_coordinate)
    return "a pose " + number(norm) + " map units from the origin (limit " +
           number(limits.max_coordinate) + ")";
  return "";
}

std::string sim3Problem(const geometry::Sim3& S, const MessageLimits& limits) {
  if (!S.rotation().coeffs().allFinite() || !S.translation().allFinite() ||
      !std::isfinite(S.logScale()))
    return "a non-finite Sim(3)";
  if (std::abs(S.logScale()) > std::log(limits.max_scale_ratio))
    return "a Sim(3) of scale " + number(S.scale()) + " (limit a factor " +
           number(limits.max_scale_ratio) + ")";
  if (S.translation().norm() > limits.max_coordinate)
    return "a Sim(3) translation of " + number(S.translation().norm()) + " map units";
  return "";
}

std::string pointProblem(const Eigen::Vector3d& p, const MessageLimits& limits) {
  if (!p.allFinite()) return "a non-finite position";
  if (p.norm() > limits.max_coordinate)
    return "a position " + number(p.norm()) + " map units from the origin";
  return "";
}

bool badNormalised(const Eigen::Vector2d& xy, const MessageLimits& limits) {
  return !xy.allFinite() || xy.lpNorm<Eigen::Infinity>() > limits.max_normalised;
}

std::string sizeProblem(std::size_t size, int limit, const std::string& what) {
  if (size <= static_cast<std::size_t>(limit)) return "";
  return std::to_string(size) + " " + what + " (limit " + std::to_string(limit) + ")";
}

std::string imageProblem(const cv::Mat& image, const MessageLimits& limits) {
  if (image.cols > limits.max_image_side || image.rows > limits.max_image_side)
    return "an image of " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
           " pixels (limit " + std::to_string(limits.max_image_side) + " a side)";
  return "";
}

std::string observationsProblem(const map::KeyframeMessage& message, const MessageLimits& limits) {
  const map::Keyframe& keyframe = message.keyframe;
  std::string problem =
      sizeProblem(keyframe.observations.size(), limits.max_observations, "observations");
  if (problem.empty())
    problem = sizeProblem(message.earlier_observations.size(), limits.max_observations,
                          "earlier observations");
  if (problem.empty())
    problem = sizeProblem(message.new_points.size(), limits.max_new_points, "new points");
  if (!problem.empty()) return problem;
  for (const map::Observation& o : keyframe.observations) {
    if (badNormalised(o.xyd(), limits))
      return "an observation of point " + std::to_string(o.point_id) + " at a non-finite or " +
             "absurd position";
  }
  for (const map::KeyframeObservation& o : message.earlier_observations) {
    if (o.keyframe_id > keyframe.id)
      return "an earlier observation in keyframe " + std::to_string(o.keyframe_id) +
             ", which is later than this one";
    if (badNormalised(o.xy, limits))
      return "an earlier observation of point " + std::to_string(o.point_id) +
             " at a non-finite or absurd position";
  }
  for (const map::NewMapPoint& p : message.new_points) {
    const std::string point = pointProblem(p.p_world, limits);
    if (!point.empty()) return "new point " + std::to_string(p.id) + " with " + point;
    if (p.reference_keyframe > keyframe.id)
      return "new point " + std::to_string(p.id) + " anchored to the later keyframe " +
             std::to_string(p.reference_keyframe);
  }
  return "";
}

}  // namespace

void MessageLimits::validate() const {
  auto positive = [](double value, const char* name) {
    if (!(value > 0.0) || !std::isfinite(value))
      throw std::invalid_argument(std::string("messages.") + name + " must be positive, got " +
                                  number(value));
  };
  positive(max_observations, "max_observations");
  positive(max_new_points, "max_new_points");
  positive(max_keyframe_id_gap, "max_keyframe_id_gap");
  positive(max_update_entries, "max_update_entries");
  positive(max_found_points, "max_found_points");
  positive(max_image_side, "max_image_side");
  positive(max_coordinate, "max_coordinate");
  positive(max_normalised, "max_normalised");
  if (!(max_scale_ratio > 1.0) || !std::isfinite(max_scale_ratio))
    throw std::invalid_argument("messages.max_scale_ratio must be above 1, got " +
                                number(max_scale_ratio));
}

std::string keyframeProblem(const map::KeyframeMessage& message, const MessageLimits& limits) {
  const map::Keyframe& keyframe = message.keyframe;
  const std::string name = "keyframe " + std::to_string(keyframe.id) + " has ";
  if (!std::isfinite(keyframe.timestamp)) return name + "a non-finite stamp";
  std::string problem = poseProblem(keyframe.T_kf_world, limits);
  if (problem.empty()) problem = observationsProblem(message, limits);
  if (problem.empty()) problem = imageProblem(message.image, limits);
  return problem.empty() ? "" : name + problem;
}

std::string cameraProblem(const geometry::CameraCalibration& camera) {
  try {
    camera.validate();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

std::string keyframeIdProblem(map::KeyframeId id, std::optional<map::KeyframeId> newest_held,
                              const MessageLimits& limits) {
  if (!newest_held || id <= *newest_held) return "";
  const std::uint64_t gap = static_cast<std::uint64_t>(id) - *newest_held;
  if (gap <= static_cast<std::uint64_t>(limits.max_keyframe_id_gap)) return "";
  return "keyframe " + std::to_string(id) + " is " + std::to_string(gap) +
         " ids ahead of the newest one held (" + std::to_string(*newest_held) + ", limit " +
         std::to_string(limits.max_keyframe_id_gap) + "): not from this session's tracker";
}

std::string mapUpdateProblem(const map::MapUpdate& update, const MessageLimits& limits) {
  const std::string name = "map update " + std::to_string(update.map_version) + " has ";
  std::string problem;
  for (const auto& [size, what] :
       {std::pair{update.keyframe_poses.size(), "keyframe poses"},
        std::pair{update.point_positions.size(), "point positions"},
        std::pair{update.removed_points.size(), "removed points"},
        std::pair{update.culled_keyframes.size(), "culled keyframes"},
        std::pair{update.keyframe_corrections.size(), "keyframe corrections"},
        std::pair{update.loop_links.size(), "loop links"}}) {
    problem = sizeProblem(size, limits.max_update_entries, what);
    if (!problem.empty()) return name + problem;
  }
  if (update.S_new_old) problem = sim3Problem(*update.S_new_old, limits);
  for (const auto& [id, pose] : update.keyframe_poses) {
    if (!problem.empty()) break;
    problem = poseProblem(pose, limits);
    if (!problem.empty()) problem += " for keyframe " + std::to_string(id);
  }
  for (const auto& [id, p] : update.point_positions) {
    if (!problem.empty()) break;
    problem = pointProblem(p, limits);
    if (!problem.empty()) problem += " for point " + std::to_string(id);
  }
  for (const auto& [id, C] : update.keyframe_corrections) {
    if (!problem.empty()) break;
    problem = sim3Problem(C, limits);
    if (!problem.empty()) problem += " correcting keyframe " + std::to_string(id);
  }
  return problem.empty() ? "" : name + problem;
}

std::string loopConstraintProblem(const loop::LoopConstraint& constraint,
                                  const MessageLimits& limits) {
  const std::string name = "loop " + std::to_string(constraint.current_id) + " -> " +
                           std::to_string(constraint.loop_id) + " has ";
  if (constraint.current_id == constraint.loop_id) return name + "the same keyframe at both ends";
  std::string problem = sim3Problem(constraint.S_current_loop, limits);
  if (problem.empty()) problem = poseProblem(constraint.T_current_loop, limits);
  if (problem.empty() && !(std::isfinite(constraint.scale) && constraint.scale > 0.0))
    problem = "a scale of " + number(constraint.scale);
  if (problem.empty() && (constraint.num_inliers < 0 || constraint.num_matches < 0 ||
                          constraint.num_scale_pairs < 0 || !std::isfinite(constraint.rmse_px)))
    problem = "negative counts or a non-finite RMSE";
  return problem.empty() ? "" : name + problem;
}

std::string relocalisationRequestProblem(const map::RelocalisationRequest& request,
                                         const MessageLimits& limits) {
  const std::string name =
      "relocalisation request of frame " + std::to_string(request.frame_index) + " has ";
  if (!std::isfinite(request.timestamp)) return name + "a non-finite stamp";
  if (request.image.empty()) return name + "no image";
  const std::string problem = imageProblem(request.image, limits);
  return problem.empty() ? "" : name + problem;
}

std::string relocalisationAnswerProblem(const map::RelocalisationAnswer& answer,
                                        const MessageLimits& limits) {
  const std::string name =
      "relocalisation answer of frame " + std::to_string(answer.frame_index) + " has ";
  if (!std::isfinite(answer.timestamp)) return name + "a non-finite stamp";
  if (answer.inliers < 0) return name + "a negative inlier count";
  std::string problem = sizeProblem(answer.points.size(), limits.max_found_points, "points");
  if (problem.empty() && answer.success) problem = poseProblem(answer.T_cam_world, limits);
  for (const map::RelocalisationAnswer::FoundPoint& p : answer.points) {
    if (!problem.empty()) break;
    if (!p.px.allFinite() || p.px.lpNorm<Eigen::Infinity>() > limits.max_image_side ||
        badNormalised(p.xy, limits))
      problem = "point " + std::to_string(p.id) + " at a non-finite or absurd position";
  }
  return problem.empty() ? "" : name + problem;
}

namespace {

std::string aheadOf(map::KeyframeId id, std::optional<map::KeyframeId> newest_made) {
  return "keyframe " + std::to_string(id) + ", which the tracker never made (" +
         (newest_made ? "its newest is " + std::to_string(*newest_made) : "it made none yet") + ")";
}

bool ahead(map::KeyframeId id, std::optional<map::KeyframeId> newest_made) {
  return !newest_made || id > *newest_made;
}

}  // namespace

std::string trackerIdsProblem(const map::MapUpdate& update,
                              std::optional<map::KeyframeId> newest_made) {
  const std::string name = "map update " + std::to_string(update.map_version) + " names ";
  for (const auto& [id, pose] : update.keyframe_poses)
    if (ahead(id, newest_made)) return name + aheadOf(id, newest_made);
  for (const auto& [id, C] : update.keyframe_corrections)
    if (ahead(id, newest_made)) return name + aheadOf(id, newest_made);
  for (const auto& [from, to] : update.loop_links)
    if (ahead(std::max(from, to), newest_made))
      return name + aheadOf(std::max(from, to), newest_made);
  return "";
}

std::string trackerIdsProblem(const map::RelocalisationAnswer& answer,
                              std::optional<map::KeyframeId> newest_made) {
  if (!answer.success || !ahead(answer.keyframe_id, newest_made)) return "";
  return "relocalisation answer of frame " + std::to_string(answer.frame_index) + " names " +
         aheadOf(answer.keyframe_id, newest_made);
}

}  // namespace scale_drift_slam::system
