#include "scale_drift_slam/sim/loop_measurement.h"

#include <stdexcept>
#include <string>
#include <unordered_map>

namespace scale_drift_slam::sim {

void LoopDetectionParams::validate() const {
  auto fail = [](const std::string& what) {
    throw std::invalid_argument("loop detection: " + what);
  };
  if (min_shared_points < 4) fail("min_shared_points must be >= 4");
  if (min_keyframe_gap < 1) fail("min_keyframe_gap must be >= 1");
  if (cooldown_keyframes < 0) fail("cooldown_keyframes must be >= 0");
  constraint.validate();
}

loop::LoopConstraintResult measureLoop(const SimulatedVisualOdometry& vo, std::size_t current,
                                       std::size_t loop, double focal_length_px,
                                       const loop::LoopConstraintParams& params) {
  if (current >= vo.keyframes().size() || loop >= vo.keyframes().size()) {
    throw std::out_of_range("measureLoop: keyframe index out of range");
  }
  const map::Map& map = vo.map();
  const KeyframeRecord& c_record = vo.keyframes()[current];
  const map::Keyframe& c = map.keyframe(c_record.id);
  const map::Keyframe& l = map.keyframe(vo.keyframes()[loop].id);
  // The loop keyframe's points by simulated point, in its camera frame.
  std::unordered_map<int, Eigen::Vector3d> loop_points;
  for (const map::Observation& o : l.observations) {
    loop_points[vo.simPointOf(o.point_id)] = l.T_kf_world * map.point(o.point_id).p_world;
  }
  loop::LoopConstraintInput input;
  input.current_id = c.id;
  input.loop_id = l.id;
  input.focal_length_px = focal_length_px;
  for (const auto& [sim_id, xy] : c_record.measurements) {
    const auto it = loop_points.find(sim_id);
    if (it != loop_points.end()) input.matches.push_back({xy, it->second});
  }
  for (const map::Observation& o : c.observations) {
    const auto it = loop_points.find(vo.simPointOf(o.point_id));
    if (it == loop_points.end()) continue;
    input.point_pairs.push_back({c.T_kf_world * map.point(o.point_id).p_world, it->second});
  }
  return loop::estimateLoopConstraint(input, params);
}

std::vector<loop::LoopConstraint> detectLoops(const SimulatedVisualOdometry& vo,
                                              double focal_length_px,
                                              const LoopDetectionParams& params) {
  params.validate();
  const map::Map& map = vo.map();
  const auto& keyframes = vo.keyframes();
  std::unordered_map<map::KeyframeId, std::size_t> index;
  for (std::size_t k = 0; k < keyframes.size(); ++k)
    index[keyframes[k].id] = k;
  // Every keyframe observing a map point of each simulated point (in keyframe order).
  std::unordered_map<int, std::vector<std::size_t>> seen_by;
  for (const auto& [id, point] : map.points()) {
    std::vector<std::size_t>& list = seen_by[vo.simPointOf(id)];
    for (map::KeyframeId kf : point.observed_by)
      list.push_back(index.at(kf));
  }
  std::vector<loop::LoopConstraint> loops;
  std::size_t next_allowed = 0;
  for (std::size_t c = 0; c < keyframes.size(); ++c) {
    if (c < next_allowed || c < static_cast<std::size_t>(params.min_keyframe_gap)) continue;
    std::unordered_map<std::size_t, int> votes;
    for (const auto& [sim_id, xy] : keyframes[c].measurements) {
      const auto it = seen_by.find(sim_id);
      if (it == seen_by.end()) continue;
      for (std::size_t k : it->second) {
        if (k + params.min_keyframe_gap <= c) ++votes[k];
      }
    }
    std::size_t best = 0;
    int best_votes = 0;
    for (const auto& [k, n] : votes) {
      if (n > best_votes || (n == best_votes && k < best)) best = k, best_votes = n;
    }
    if (best_votes < params.min_shared_points) continue;
    const loop::LoopConstraintResult result =
        measureLoop(vo, c, best, focal_length_px, params.constraint);
    if (!result.success) continue;
    loops.push_back(result.constraint);
    next_allowed = c + params.cooldown_keyframes;
  }
  return loops;
}

}  // namespace scale_drift_slam::sim
