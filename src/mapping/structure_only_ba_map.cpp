// The map side of structure-only BA (mapping/structure_only_ba.h): gathering the points and their
// observations from a map::Map into a StructureOnlyProblem, and writing the result back.

#include <algorithm>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "scale_drift_slam/common/stopwatch.h"

#include "scale_drift_slam/mapping/structure_only_ba.h"

namespace scale_drift_slam::mapping {

namespace {

/// Point id -> index in the refined list: a plain vector when the ids are dense (as in maps
/// built by the SLAM), a hash map otherwise.
class PointIndex {
 public:
  static constexpr std::size_t kNone = static_cast<std::size_t>(-1);

  explicit PointIndex(const std::vector<map::PointId>& ids) {
    const map::PointId max_id = ids.empty() ? 0 : *std::max_element(ids.begin(), ids.end());
    dense_ = max_id < 4 * ids.size() + 1024;
    if (dense_) {
      dense_index_.assign(static_cast<std::size_t>(max_id) + 1, kNone);
    }
    for (std::size_t i = 0; i < ids.size(); ++i) {
      const bool fresh =
          dense_ ? dense_index_[ids[i]] == kNone : sparse_index_.emplace(ids[i], i).second;
      if (!fresh) {
        throw std::invalid_argument("structure-only BA: point " + std::to_string(ids[i]) +
                                    " listed twice");
      }
      if (dense_) {
        dense_index_[ids[i]] = i;
      }
    }
  }

  std::size_t find(map::PointId id) const {
    if (dense_) {
      return id < dense_index_.size() ? dense_index_[id] : kNone;
    }
    const auto it = sparse_index_.find(id);
    return it == sparse_index_.end() ? kNone : it->second;
  }

 private:
  bool dense_ = false;
  std::vector<std::size_t> dense_index_;
  std::unordered_map<map::PointId, std::size_t> sparse_index_;
};

/// `points`, or all points of the map in increasing id order when it is empty.
std::vector<map::PointId> pointIds(const map::Map& map, const std::vector<map::PointId>& points) {
  if (!points.empty()) {
    return points;
  }
  std::vector<map::PointId> ids;
  ids.reserve(map.numPoints());
  for (const auto& entry : map.points()) {
    ids.push_back(entry.first);
  }
  std::sort(ids.begin(), ids.end());
  return ids;
}

}  // namespace

StructureOnlyProblem makeStructureOnlyProblem(const map::Map& map,
                                              const std::vector<map::PointId>& points) {
  const std::vector<map::PointId> ids = pointIds(map, points);
  StructureOnlyProblem problem;
  const PointIndex index(ids);
  problem.points.reserve(ids.size());
  for (const map::PointId id : ids) {
    problem.points.push_back(map.point(id).p_world);  // throws
  }
  problem.first_observation.assign(ids.size() + 1, 0);
  for (const auto& [id, keyframe] : map.keyframes()) {
    problem.T_cam_world.push_back(keyframe.T_kf_world);
    for (const map::Observation& obs : keyframe.observations) {
      const std::size_t i = index.find(obs.point_id);
      if (i != PointIndex::kNone) {
        ++problem.first_observation[i + 1];
      }
    }
  }
  for (std::size_t i = 0; i < ids.size(); ++i) {
    problem.first_observation[i + 1] += problem.first_observation[i];
  }
  problem.observations.resize(problem.first_observation.back());
  std::vector<std::size_t> fill(problem.first_observation.begin(),
                                problem.first_observation.end() - 1);
  std::size_t pose = 0;
  for (const auto& entry : map.keyframes()) {
    for (const map::Observation& obs : entry.second.observations) {
      const std::size_t i = index.find(obs.point_id);
      if (i != PointIndex::kNone) {
        problem.observations[fill[i]++] = {pose, obs.xyd()};
      }
    }
    ++pose;
  }
  return problem;
}

StructureOnlyBAResult refineStructure(map::Map& map, const std::vector<map::PointId>& points,
                                      const Eigen::Vector2d& focal_length_px,
                                      const StructureOnlyBAOptions& options) {
  const common::Stopwatch timer;
  const std::vector<map::PointId> ids = pointIds(map, points);
  StructureOnlyProblem problem = makeStructureOnlyProblem(map, ids);
  StructureOnlyBAResult result = refineStructure(problem, focal_length_px, options);
  for (std::size_t i = 0; i < ids.size(); ++i) {
    map.point(ids[i]).p_world = problem.points[i];
  }
  map.bumpVersion();
  result.time_s = timer.seconds();
  return result;
}

}  // namespace scale_drift_slam::mapping
