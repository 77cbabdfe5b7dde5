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

/// Dense indices of the selected keyframes (in id order) by keyframe id; kNone for the others.
class KeyframeIndex {
 public:
  static constexpr std::uint32_t kNone = static_cast<std::uint32_t>(-1);

  explicit KeyframeIndex(const std::set<map::KeyframeId>& selected)
      : ids_(selected.begin(), selected.end()) {
    const map::KeyframeId largest = ids_.empty() ? 0 : ids_.back();
    dense_ = largest < 4 * ids_.size() + 1024;
    if (dense_) dense_index_.assign(std::size_t{largest} + 1, kNone);
    for (std::uint32_t i = 0; i < ids_.size(); ++i) {
      if (dense_) {
        dense_index_[ids_[i]] = i;
      } else {
        sparse_index_.emplace(ids_[i], i);
      }
    }
  }
  std::uint32_t find(map::KeyframeId id) const {
    if (dense_) return id < dense_index_.size() ? dense_index_[id] : kNone;
    const auto it = sparse_index_.find(id);
    return it == sparse_index_.end() ? kNone : it->second;
  }
  map::KeyframeId id(std::uint32_t index) const { return ids_[index]; }
  std::size_t size() const { return ids_.size(); }

 private:
  std::vector<map::KeyframeId> ids_;
  bool dense_ = false;
  std::vector<std::uint32_t> dense_index_;
  std::unordered_map<map::KeyframeId, std::uint32_t> sparse_index_;
};

/// Number of points shared by each pair (older, newer) of selected keyframes, in pair order.
/// One pass over the points. Co-visible keyframes are mostly close in the sequence: pairs at most
/// kBand apart (in the selection's order) are counted in a dense table, the others (across a
/// loop, a revisit) in a hash of 64-bit pair keys (a map of 2300 keyframes and 240 000 points
/// takes ~10 ms).
std::vector<std::pair<std::pair<map::KeyframeId, map::KeyframeId>, int>> sharedPoints(
    const map::Map& map, const std::set<map::KeyframeId>& selected) {
  constexpr std::uint32_t kBand = 32;
  const KeyframeIndex index(selected);
  std::vector<int> near(index.size() * kBand, 0);  // [newer * kBand + (newer - older - 1)]
  std::unordered_map<std::uint64_t, int> far;
  std::vector<std::uint32_t> observers;
  for (const auto& entry : map.points()) {
    observers.clear();
    for (const map::KeyframeId id : entry.second.observed_by) {
      const std::uint32_t i = index.find(id);
      if (i != KeyframeIndex::kNone) observers.push_back(i);
    }
    std::sort(observers.begin(), observers.end());
    observers.erase(std::unique(observers.begin(), observers.end()), observers.end());
    for (std::size_t a = 0; a < observers.size(); ++a) {
      for (std::size_t b = a + 1; b < observers.size(); ++b) {
        const std::uint32_t gap = observers[b] - observers[a];
        if (gap <= kBand) {
          ++near[std::size_t{observers[b]} * kBand + gap - 1];
        } else {
          ++far[(std::uint64_t{observers[a]} << 32) | observers[b]];
        }
      }
    }
  }
  std::vector<std::pair<std::pair<map::KeyframeId, map::KeyframeId>, int>> pairs;
  for (std::uint32_t newer = 0; newer < index.size(); ++newer) {
    for (std::uint32_t gap = 1; gap <= kBand && gap <= newer; ++gap) {
      const int count = near[std::size_t{newer} * kBand + gap - 1];
      if (count > 0) pairs.push_back({{index.id(newer - gap), index.id(newer)}, count});
    }
  }
  for (const auto& [key, count] : far) {
    pairs.push_back({{index.id(static_cast<std::uint32_t>(key >> 32)),
                      index.id(static_cast<std::uint32_t>(key & 0xffffffffu))},
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
