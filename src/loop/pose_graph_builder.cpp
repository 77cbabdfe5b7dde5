#include "scale_drift_slam/loop/pose_graph_builder.h"

#include <algorithm>
#include <cstdint>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

namespace scale_drift_slam::loop {
namespace {

using geometry::Sim3;

PoseGraphEdge relativeEdge(const map::Map& map, map::KeyframeId newer, map::KeyframeId older,
                           EdgeKind kind, const Matrix7d& information) {
  PoseGraphEdge edge;
  edge.from = newer;
  edge.to = older;
  edge.S_from_to = Sim3(map.keyframe(newer).T_kf_world * map.keyframe(older).T_kf_world.inverse());
  edge.information = information;
  edge.kind = kind;
  return edge;
}

/// Number of points shared by each pair (older, newer) of selected keyframes, in pair order.
/// One pass over the points with a hash of 64-bit pair keys (maps of 10^5 points, 10^3 keyframes
/// take milliseconds).
std::vector<std::pair<std::pair<map::KeyframeId, map::KeyframeId>, int>> sharedPoints(
    const map::Map& map, const std::set<map::KeyframeId>& selected) {
  const bool all = selected.size() == map.numKeyframes();
  std::unordered_map<std::uint64_t, int> shared;
  std::vector<map::KeyframeId> observers;
  for (const auto& entry : map.points()) {
    observers.clear();
    for (const map::KeyframeId id : entry.second.observed_by) {
      if (all || selected.count(id)) observers.push_back(id);
    }
    std::sort(observers.begin(), observers.end());
    observers.erase(std::unique(observers.begin(), observers.end()), observers.end());
    for (std::size_t a = 0; a < observers.size(); ++a) {
      for (std::size_t b = a + 1; b < observers.size(); ++b)
        ++shared[(std::uint64_t{observers[a]} << 32) | observers[b]];
    }
  }
  std::vector<std::pair<std::pair<map::KeyframeId, map::KeyframeId>, int>> pairs;
  pairs.reserve(shared.size());
  for (const auto& [key, count] : shared) {
    pairs.push_back(
        {{static_cast<map::KeyframeId>(key >> 32), static_cast<map::KeyframeId>(key & 0xffffffffu)},
         count});
  }
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

}  // namespace

void PoseGraphBuilderOptions::validate() const {
  if (min_shared_points < 0 || max_covisibility_edges_per_keyframe < 0) {
    throw std::invalid_argument(
        "pose graph builder: min_shared_points and max_covisibility_edges_per_keyframe must be "
        ">= 0");
  }
  if (!information.allFinite()) {
    throw std::invalid_argument("pose graph builder: information must be finite");
  }
}

PoseGraph buildPoseGraph(const map::Map& map, const std::vector<map::KeyframeId>& keyframes,
                         const std::vector<PoseGraphEdge>& loop_edges,
                         const std::vector<map::KeyframeId>& fixed,
                         const PoseGraphBuilderOptions& options) {
  options.validate();
  std::set<map::KeyframeId> selected(keyframes.begin(), keyframes.end());
  if (keyframes.empty()) {
    for (const auto& entry : map.keyframes()) {
      selected.insert(entry.first);
    }
  }
  PoseGraph graph;
  for (const map::KeyframeId id : selected) {
    if (!map.hasKeyframe(id)) {
      throw std::invalid_argument("pose graph builder: keyframe " + std::to_string(id) +
                                  " is not in the map");
    }
    graph.addVertex(id, Sim3(map.keyframe(id).T_kf_world));
  }
  for (const map::KeyframeId id : fixed) {
    if (!selected.count(id)) {
      throw std::invalid_argument("pose graph builder: fixed keyframe " + std::to_string(id) +
                                  " is not in the graph");
    }
    graph.setFixed(id);
  }
  std::set<std::pair<map::KeyframeId, map::KeyframeId>> consecutive;
  if (options.consecutive_edges) {
    for (auto it = selected.begin(); it != selected.end() && std::next(it) != selected.end();
         ++it) {
      const map::KeyframeId older = *it, newer = *std::next(it);
      graph.addEdge(relativeEdge(map, newer, older, EdgeKind::kConsecutive, options.information));
      consecutive.insert({older, newer});
    }
  }
  if (options.min_shared_points > 0) {
    // Candidates per newer keyframe: (shared points, older keyframe), strongest first.
    std::map<map::KeyframeId, std::vector<std::pair<int, map::KeyframeId>>> candidates;
    for (const auto& [pair, count] : sharedPoints(map, selected)) {
      if (count >= options.min_shared_points && !consecutive.count(pair)) {
        candidates[pair.second].emplace_back(count, pair.first);
      }
    }
    for (auto& [newer, olders] : candidates) {
      std::stable_sort(olders.begin(), olders.end(),
                       [](const auto& a, const auto& b) { return a.first > b.first; });
      const std::size_t limit =
          options.max_covisibility_edges_per_keyframe > 0
              ? static_cast<std::size_t>(options.max_covisibility_edges_per_keyframe)
              : olders.size();
      for (std::size_t k = 0; k < std::min(limit, olders.size()); ++k) {
        graph.addEdge(relativeEdge(map, newer, olders[k].second, EdgeKind::kCovisibility,
                                   options.information));
      }
    }
  }
  for (const PoseGraphEdge& edge : loop_edges) {
    if (!selected.count(edge.from) || !selected.count(edge.to)) {
      throw std::invalid_argument("pose graph builder: loop edge " + std::to_string(edge.from) +
                                  " -> " + std::to_string(edge.to) +
                                  " joins a keyframe outside the graph");
    }
    graph.addEdge(edge);
  }
  return graph;
}

}  // namespace scale_drift_slam::loop
