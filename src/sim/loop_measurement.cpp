#include "scale_drift_slam/sim/loop_measurement.h"

#include <algorithm>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "scale_drift_slam/common/statistics.h"
#include "scale_drift_slam/mapping/structure_only_ba.h"

namespace scale_drift_slam::sim {

void LoopDetectionParams::validate() const {
  auto fail = [](const std::string& what) {
    throw std::invalid_argument("loop detection: " + what);
  };
  if (min_shared_points < 4) fail("min_shared_points must be >= 4");
  if (min_keyframe_gap < 1) fail("min_keyframe_gap must be >= 1");
  if (cooldown_keyframes < 0) fail("cooldown_keyframes must be >= 0");
  measurement.validate();
}

void LoopMeasurementParams::validate() const {
  constraint.validate();
  if (structure_keyframes < 0) {
    throw std::invalid_argument("loop measurement: structure_keyframes must be >= 0");
  }
  if (depth_neighbours < 1) throw std::invalid_argument("loop measurement: depth_neighbours >= 1");
  if (!(depth_radius_px > 0.0)) {
    throw std::invalid_argument("loop measurement: depth_radius_px must be > 0");
  }
}

std::unordered_map<int, Eigen::Vector3d> localStructure(const SimulatedVisualOdometry& vo,
                                                        std::size_t k, int radius,
                                                        double focal_length_px) {
  const map::Map& map = vo.map();
  const auto& keyframes = vo.keyframes();
  const map::Keyframe& kf = map.keyframe(keyframes.at(k).id);
  // Keyframe ids are indices into keyframes() (SimulatedVisualOdometry numbers them so).
  auto near = [&](map::KeyframeId id) {
    return std::abs(static_cast<long>(id) - static_cast<long>(k)) <= radius;
  };
  mapping::StructureOnlyProblem problem;
  std::unordered_map<map::KeyframeId, std::size_t> pose_index;
  std::vector<int> sim_ids;
  for (const map::Observation& o : kf.observations) {
    const map::MapPoint& point = map.point(o.point_id);
    problem.first_observation.push_back(problem.observations.size());
    problem.points.push_back(point.p_world);
    sim_ids.push_back(vo.simPointOf(o.point_id));
    if (radius == 0) continue;
    for (map::KeyframeId id : point.observed_by) {
      if (!near(id)) continue;
      const auto [entry, inserted] = pose_index.try_emplace(id, problem.T_cam_world.size());
      if (inserted) problem.T_cam_world.push_back(map.keyframe(id).T_kf_world);
      for (const map::Observation& other : map.keyframe(id).observations) {
        if (other.point_id == o.point_id)
          problem.observations.push_back({entry->second, other.xyd()});
      }
    }
  }
  problem.first_observation.push_back(problem.observations.size());
  if (radius > 0) {
    mapping::refineStructure(problem, Eigen::Vector2d::Constant(focal_length_px),
                             mapping::StructureOnlyBAOptions());
  }
  std::unordered_map<int, Eigen::Vector3d> structure;
  for (std::size_t i = 0; i < sim_ids.size(); ++i)
    structure[sim_ids[i]] = kf.T_kf_world * problem.points[i];
  return structure;
}

namespace {

/// The depth (z) of a feature at `xy` by k-nearest-neighbour regression on the points a keyframe
/// holds (in its camera frame): the median z of the nearest `depth_neighbours` whose projections
/// lie within `depth_radius_px`; 0 when fewer than that many do (doc/algorithm.md, "Loop
/// closure detection", steps 2 and 4).
double regressedDepth(const std::unordered_map<int, Eigen::Vector3d>& points,
                      const Eigen::Vector2d& xy, double focal_length_px,
                      const LoopMeasurementParams& params) {
  std::vector<std::pair<double, double>> neighbours;  // (pixel distance, z)
  for (const auto& entry : points) {
    const Eigen::Vector3d& p = entry.second;
    if (!(p.z() > 0.0)) continue;
    const double distance = focal_length_px * (p.head<2>() / p.z() - xy).norm();
    if (distance <= params.depth_radius_px) neighbours.emplace_back(distance, p.z());
  }
  const std::size_t k = static_cast<std::size_t>(params.depth_neighbours);
  if (neighbours.size() < k) return 0.0;
  std::partial_sort(neighbours.begin(), neighbours.begin() + k, neighbours.end());
  std::vector<double> depths;
  for (std::size_t i = 0; i < k; ++i)
    depths.push_back(neighbours[i].second);
  return common::upperMedian(std::move(depths));
}

}  // namespace

loop::LoopConstraintResult measureLoop(const SimulatedVisualOdometry& vo, std::size_t current,
                                       std::size_t loop, double focal_length_px,
                                       const LoopMeasurementParams& params) {
  params.validate();
  if (current >= vo.keyframes().size() || loop >= vo.keyframes().size()) {
    throw std::out_of_range("measureLoop: keyframe index out of range");
  }
  const KeyframeRecord& c_record = vo.keyframes()[current];
  const std::unordered_map<int, Eigen::Vector3d> loop_points =
      localStructure(vo, loop, params.structure_keyframes, focal_length_px);
  const std::unordered_map<int, Eigen::Vector3d> current_points =
      localStructure(vo, current, params.structure_keyframes, focal_length_px);
  loop::LoopConstraintInput input;
  input.current_id = c_record.id;
  input.loop_id = vo.keyframes()[loop].id;
  input.focal_length_px = focal_length_px;
  for (const auto& [sim_id, xy] : c_record.measurements) {
    const auto it = loop_points.find(sim_id);
    if (it != loop_points.end()) input.matches.push_back({xy, it->second});
  }
  // 3D-3D pairs: the same point in both maps; where the current map does not hold a matched point
  // (yet), the feature's depth from its neighbours in the current keyframe (paper, step 4).
  for (const auto& [sim_id, xy] : c_record.measurements) {
    const auto loop_point = loop_points.find(sim_id);
    if (loop_point == loop_points.end()) continue;
    const auto current_point = current_points.find(sim_id);
    if (current_point != current_points.end()) {
      input.point_pairs.push_back({current_point->second, loop_point->second});
      continue;
    }
    const double depth = regressedDepth(current_points, xy, focal_length_px, params);
    if (depth > 0.0) input.point_pairs.push_back({depth * xy.homogeneous(), loop_point->second});
  }
  return loop::estimateLoopConstraint(input, params.constraint);
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
        measureLoop(vo, c, best, focal_length_px, params.measurement);
    if (!result.success) continue;
    loops.push_back(result.constraint);
    next_allowed = c + params.cooldown_keyframes;
  }
  return loops;
}

}  // namespace scale_drift_slam::sim
