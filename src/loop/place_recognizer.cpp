#include "scale_drift_slam/loop/place_recognizer.h"

#include <cmath>

#include <algorithm>
#include <cstdio>
#include <limits>
#include <stdexcept>

namespace scale_drift_slam::loop {
namespace {

std::string format(const char* pattern, double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), pattern, value);
  return buffer;
}

}  // namespace

const char* toString(CandidateStatus status) {
  switch (status) {
    case CandidateStatus::kAccepted:
      return "accepted";
    case CandidateStatus::kFailedGeometry:
      return "failed geometry";
    case CandidateStatus::kNotYetConsistent:
      return "not yet consistent";
    case CandidateStatus::kContinuesLoop:
      return "continues an accepted loop";
  }
  return "unknown";
}

const LoopCandidate* PlaceQueryResult::accepted() const {
  for (const LoopCandidate& candidate : candidates) {
    if (candidate.status == CandidateStatus::kAccepted) return &candidate;
  }
  return nullptr;
}

std::string PlaceQueryResult::describe() const {
  std::string text = "query " + std::to_string(query_id) + ": ";
  if (!searched) return text + "skipped (" + skip_reason + ")";
  if (const LoopCandidate* loop = accepted()) {
    return text + "loop with keyframe " + std::to_string(loop->keyframe_id) + " (score " +
           format("%.3f", loop->score) + ", normalised " + format("%.2f", loop->normalized_score) +
           ", " + std::to_string(loop->geometry.inliers) + " inliers, coverage " +
           format("%.2f", loop->geometry.coverage) + ", scale change " +
           format("%.2f", loop->geometry.scale_change) + ", " +
           std::to_string(loop->consistent_queries) + " queries in a streak)";
  }
  if (candidates.empty()) {
    return text + "no candidate above the normalised score (" +
           std::to_string(keyframes_considered) + " keyframes considered, reference score " +
           format("%.3f", reference_score) + ")";
  }
  const LoopCandidate& best = candidates.front();
  return text + "no loop; best candidate " + std::to_string(best.keyframe_id) + " (normalised " +
         format("%.2f", best.normalized_score) + "): " + toString(best.status) + ": " + best.reason;
}

PlaceRecognizer::PlaceRecognizer(PlaceRecognitionParams params,
                                 std::shared_ptr<const Vocabulary> vocabulary)
    : params_(std::move(params)), vocabulary_(std::move(vocabulary)) {
  params_.validate();
  if (!vocabulary_ && !params_.vocabulary_file.empty()) {
    vocabulary_ = std::make_shared<const Vocabulary>(Vocabulary::load(params_.vocabulary_file));
  }
  if (vocabulary_ && vocabulary_->empty()) {
    throw std::invalid_argument("place recognizer: the given vocabulary is empty");
  }
}

const KeyframeAppearance& PlaceRecognizer::appearance(map::KeyframeId id) const {
  const auto it = index_of_.find(id);
  if (it == index_of_.end()) {
    throw std::out_of_range("place recognizer: unknown keyframe " + std::to_string(id));
  }
  return keyframes_[it->second].appearance;
}

void PlaceRecognizer::add(map::KeyframeId id, double timestamp, KeyframeAppearance appearance) {
  if (contains(id)) {
    throw std::invalid_argument("place recognizer: keyframe " + std::to_string(id) +
                                " was already added");
  }
  appearance.validate();
  index_of_[id] = keyframes_.size();
  keyframes_.push_back(Stored{id, timestamp, std::move(appearance), {}});
  if (vocabulary_) {
    index(keyframes_.size() - 1);
  } else if (static_cast<int>(keyframes_.size()) >= params_.online_training_keyframes) {
    trainOnlineVocabulary();
  }
}

std::vector<PlaceRecognizer::Place> PlaceRecognizer::places() const {
  std::vector<Place> places;
  places.reserve(keyframes_.size());
  for (std::size_t i = 0; i < keyframes_.size(); ++i) {
    const Stored& stored = keyframes_[i];
    if (stored.forgotten) continue;
    const bool indexed = vocabulary_ && i < database_.size();
    places.push_back({stored.id, stored.timestamp, &stored.appearance,
                      indexed ? &database_.document(i) : nullptr,
                      indexed ? &stored.groups : nullptr});
  }
  return places;
}

void PlaceRecognizer::addSaved(SavedPlace place) {
  if (!place.indexed || !vocabulary_ || database_.size() != keyframes_.size()) {
    add(place.id, place.timestamp, std::move(place.appearance));
    return;
  }
  if (contains(place.id)) {
    throw std::invalid_argument("place recognizer: keyframe " + std::to_string(place.id) +
                                " was already added");
  }
  place.appearance.validate();
  const std::string name = "place recognizer: saved keyframe " + std::to_string(place.id);
  const BowVector& bow = place.bow;
  if (bow.words.size() != bow.weights.size()) throw std::invalid_argument(name + ": bad bag");
  for (std::size_t i = 0; i < bow.words.size(); ++i) {
    if (bow.words[i] >= vocabulary_->numWords() || (i > 0 && bow.words[i] <= bow.words[i - 1]) ||
        !std::isfinite(bow.weights[i]) || bow.weights[i] < 0.0f) {
      throw std::invalid_argument(name + ": a word out of range or order");
    }
  }
  const FeatureGroups& groups = place.groups;
  if (groups.nodes.size() != groups.features.size()) {
    throw std::invalid_argument(name + ": bad feature groups");
  }
  for (const std::vector<int>& features : groups.features) {
    for (const int f : features) {
      if (f < 0 || static_cast<std::size_t>(f) >= place.appearance.size()) {
        throw std::invalid_argument(name + ": a grouped feature out of range");
      }
    }
  }
  index_of_[place.id] = keyframes_.size();
  keyframes_.push_back(
      Stored{place.id, place.timestamp, std::move(place.appearance), std::move(place.groups)});
  database_.add(bow);
}

PlaceQueryResult PlaceRecognizer::queryAndAdd(map::KeyframeId id, double timestamp,
                                              KeyframeAppearance appearance,
                                              const std::unordered_set<map::KeyframeId>& excluded) {
  PlaceQueryResult result = query(id, timestamp, appearance, excluded);
  add(id, timestamp, std::move(appearance));
  return result;
}

void PlaceRecognizer::forget(map::KeyframeId id) {
  const auto it = index_of_.find(id);
  if (it == index_of_.end()) return;
  const std::size_t position = it->second;
  index_of_.erase(it);
  keyframes_[position].forgotten = true;
  if (vocabulary_) release(position);
}

void PlaceRecognizer::release(std::size_t position) {
  Stored& stored = keyframes_[position];
  const KeyframeAppearance& old = stored.appearance;
  KeyframeAppearance none;
  none.image_width = old.image_width;
  none.image_height = old.image_height;
  none.undistorted = old.undistorted;
  stored.appearance = std::move(none);
  stored.groups = FeatureGroups{};
  database_.forget(position);
}

void PlaceRecognizer::reportLoopRejected(map::KeyframeId query_id) {
  loops_.erase(
      std::remove_if(loops_.begin(), loops_.end(),
                     [&](const AcceptedLoop& loop) { return loop.accepted_query_id == query_id; }),
      loops_.end());
}

void PlaceRecognizer::trainOnlineVocabulary() {
  std::vector<cv::Mat> descriptors;
  for (const Stored& stored : keyframes_)
    descriptors.push_back(stored.appearance.descriptors);
  bool any = false;
  for (const cv::Mat& d : descriptors)
    any |= !d.empty();
  if (!any) return;  // nothing to learn from yet (textureless images): try at the next keyframe
  vocabulary_ =
      std::make_shared<const Vocabulary>(Vocabulary::train(descriptors, params_.vocabulary));
  for (std::size_t i = 0; i < keyframes_.size(); ++i) {
    index(i);
    if (keyframes_[i].forgotten) release(i);
  }
}

void PlaceRecognizer::index(std::size_t position) {
  Stored& stored = keyframes_[position];
  const BowVector bow = vocabulary_->transform(stored.appearance.descriptors, stored.groups,
                                               params_.geometry.group_levels_up);
  database_.add(bow);
}

PlaceQueryResult PlaceRecognizer::query(map::KeyframeId id, double timestamp,
                                        const KeyframeAppearance& appearance,
                                        const std::unordered_set<map::KeyframeId>& excluded) {
  PlaceQueryResult result;
  result.query_id = id;
  if (!vocabularyReady()) {
    result.skip_reason = "vocabulary not learned yet (" + std::to_string(keyframes_.size()) +
                         " of " + std::to_string(params_.online_training_keyframes) + " keyframes)";
    return result;
  }
  appearance.validate();
  const auto known = index_of_.find(id);
  const std::size_t position = known != index_of_.end() ? known->second : keyframes_.size();
  if (position == 0) {
    result.skip_reason = "no previous keyframe";
    return result;
  }
  FeatureGroups groups;
  const BowVector bow =
      vocabulary_->transform(appearance.descriptors, groups, params_.geometry.group_levels_up);
  result.reference_score = BowDatabase::score(bow, database_.document(position - 1));
  if (result.reference_score < params_.min_reference_score) {
    result.skip_reason = "score against the previous keyframe " +
                         format("%.4f", result.reference_score) + " below " +
                         format("%.4f", params_.min_reference_score);
    return result;
  }
  const auto recent = static_cast<std::size_t>(params_.recent_keyframes_excluded);
  const std::size_t limit = position > recent ? position - recent : 0;
  result.searched = true;
  std::vector<float> scores;
  database_.scoreAll(bow, scores);
  std::vector<Island> islands =
      findIslands(scores, result.reference_score, limit, timestamp, excluded, result);
  if (islands.size() > static_cast<std::size_t>(params_.max_islands_checked)) {
    islands.resize(static_cast<std::size_t>(params_.max_islands_checked));
  }
  for (const Island& island : islands) {
    result.candidates.push_back(
        checkIsland(island, result.reference_score, appearance, groups, params_.geometry));
  }
  decide(position, id, islands, result);
  return result;
}

std::vector<LoopCandidate> PlaceRecognizer::findPlaces(const KeyframeAppearance& appearance,
                                                       int max_candidates,
                                                       const GeometricCheckParams& geometry) const {
  if (max_candidates < 1) return {};
  appearance.validate();
  geometry.validate();
  if (!vocabularyReady()) return findRecentPlaces(appearance, max_candidates, geometry);
  if (database_.size() == 0) return {};
  FeatureGroups groups;
  const BowVector bow =
      vocabulary_->transform(appearance.descriptors, groups, params_.geometry.group_levels_up);
  std::vector<float> scores;
  database_.scoreAll(bow, scores);
  // A frame has no previous keyframe to normalise by: scores are taken relative to the best.
  // The best keyframes are checked one by one, not one per island: a lost camera is usually
  // nearest to one end of the island of its last keyframes, not to its best-scoring member.
  const double best = *std::max_element(scores.begin(), scores.end());
  if (!(best > 0.0)) return {};
  std::vector<std::size_t> order(scores.size());
  for (std::size_t i = 0; i < order.size(); ++i)
    order[i] = i;
  const std::size_t n = std::min<std::size_t>(max_candidates, order.size());
  std::partial_sort(order.begin(), order.begin() + n, order.end(),
                    [&](std::size_t a, std::size_t b) { return scores[a] > scores[b]; });
  std::vector<Island> islands;
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t i = order[k];
    if (scores[i] < params_.min_normalized_score * best) break;
    if (keyframes_[i].forgotten) continue;
    islands.push_back(Island{i, i, i, scores[i], scores[i]});
  }
  std::vector<LoopCandidate> candidates;
  for (const Island& island : islands) {
    candidates.push_back(checkIsland(island, best, appearance, groups, geometry));
    if (candidates.back().geometry.passed) candidates.back().status = CandidateStatus::kAccepted;
  }
  return candidates;
}

std::vector<LoopCandidate> PlaceRecognizer::findRecentPlaces(
    const KeyframeAppearance& appearance, int max_candidates,
    const GeometricCheckParams& geometry) const {
  // A young map (no vocabulary yet) has few keyframes, and a camera lost in it is most likely
  // near its newest ones: they are matched by brute force, newest first.
  std::vector<LoopCandidate> candidates;
  for (auto it = keyframes_.rbegin();
       it != keyframes_.rend() && static_cast<int>(candidates.size()) < max_candidates; ++it) {
    if (it->forgotten) continue;
    LoopCandidate candidate;
    candidate.keyframe_id = candidate.island_first_id = candidate.island_last_id = it->id;
    const std::vector<DescriptorMatch> matches =
        matchDescriptors(appearance, it->appearance, geometry);
    candidate.geometry = checkGeometry(appearance, it->appearance, matches, geometry);
    if (candidate.geometry.passed) {
      candidate.status = CandidateStatus::kAccepted;
    } else {
      candidate.reason = candidate.geometry.reason;
    }
    candidates.push_back(std::move(candidate));
  }
  return candidates;
}

std::vector<PlaceRecognizer::Island> PlaceRecognizer::findIslands(
    const std::vector<float>& scores, double reference, std::size_t limit, double timestamp,
    const std::unordered_set<map::KeyframeId>& excluded, PlaceQueryResult& result) const {
  std::vector<Island> islands;
  for (std::size_t i = 0; i < limit; ++i) {
    const Stored& stored = keyframes_[i];
    if (stored.forgotten) continue;
    if (params_.recent_seconds_excluded > 0.0 &&
        stored.timestamp > timestamp - params_.recent_seconds_excluded) {
      continue;
    }
    if (excluded.count(stored.id) != 0) continue;
    ++result.keyframes_considered;
    if (scores[i] / reference < params_.min_normalized_score) continue;
    ++result.keyframes_above_threshold;
    // Join the last island when within island_gap documents of its end (DLoopDetector).
    if (!islands.empty() &&
        i - islands.back().last <= static_cast<std::size_t>(params_.island_gap)) {
      Island& island = islands.back();
      island.last = i;
      island.score += scores[i];
      if (scores[i] > island.best_score) {
        island.best = i;
        island.best_score = scores[i];
      }
    } else {
      islands.push_back(Island{i, i, i, scores[i], scores[i]});
    }
  }
  // Best member first, not the islands' sums (DLoopDetector's): a sum grows with the number of
  // keyframes a place kept, which keyframe culling makes uneven (and a long island of mediocre
  // scores outweighed the revisit's 1.7 normalised score on city_tour once it was culled).
  std::stable_sort(islands.begin(), islands.end(),
                   [](const Island& a, const Island& b) { return a.best_score > b.best_score; });
  return islands;
}

LoopCandidate PlaceRecognizer::checkIsland(const Island& island, double reference,
                                           const KeyframeAppearance& appearance,
                                           const FeatureGroups& groups,
                                           const GeometricCheckParams& geometry) const {
  const Stored& best = keyframes_[island.best];
  LoopCandidate candidate;
  candidate.keyframe_id = best.id;
  candidate.score = island.best_score;
  candidate.normalized_score = island.best_score / reference;
  candidate.island_first_id = keyframes_[island.first].id;
  candidate.island_last_id = keyframes_[island.last].id;
  candidate.island_score = island.score;
  const std::vector<DescriptorMatch> matches =
      matchDescriptors(appearance, groups, best.appearance, best.groups, geometry);
  candidate.geometry = checkGeometry(appearance, best.appearance, matches, geometry);
  if (!candidate.geometry.passed) {
    candidate.status = CandidateStatus::kFailedGeometry;
    candidate.reason = candidate.geometry.reason;
  }
  return candidate;
}

void PlaceRecognizer::decide(std::size_t query_position, map::KeyframeId query_id,
                             const std::vector<Island>& checked, PlaceQueryResult& result) {
  // A streak goes on through up to `consistency_max_missed` queries that verified nothing near
  // it (on a revisit single keyframes fail the check: too few matches or too little coverage).
  const auto missed = static_cast<std::size_t>(params_.consistency_max_missed);
  const auto gap = static_cast<std::size_t>(params_.consistency_gap);
  const auto near = [](std::size_t first, std::size_t last, std::size_t other_first,
                       std::size_t other_last, std::size_t margin) {
    return first <= other_last + margin && other_first <= last + margin;
  };
  std::vector<ConsistencyGroup> groups;
  bool accepted = false;
  for (std::size_t k = 0; k < checked.size(); ++k) {
    const Island& island = checked[k];
    LoopCandidate& candidate = result.candidates[k];
    if (!candidate.geometry.passed) continue;
    int count = 1;
    for (const ConsistencyGroup& group : groups_) {
      if (group.query < query_position && query_position <= group.query + 1 + missed &&
          near(island.first, island.last, group.first, group.last, gap)) {
        count = std::max(count, group.count + 1);
      }
    }
    groups.push_back(ConsistencyGroup{island.first, island.last, count, query_position});
    candidate.consistent_queries = count;

    const auto continued = std::find_if(loops_.begin(), loops_.end(), [&](const AcceptedLoop& l) {
      const auto loop_gap = static_cast<std::size_t>(params_.continuation_gap);
      return query_position <= l.last_query + loop_gap &&
             near(island.first, island.last, l.last_candidate, l.last_candidate, loop_gap);
    });
    if (params_.suppress_loop_continuation && continued != loops_.end()) {
      candidate.status = CandidateStatus::kContinuesLoop;
      candidate.reason =
          "continues the loop accepted at query " + std::to_string(continued->accepted_query_id);
      continued->last_query = query_position;
      continued->last_candidate = island.best;
    } else if (count < params_.min_consistent_queries) {
      candidate.status = CandidateStatus::kNotYetConsistent;
      candidate.reason = "verified in " + std::to_string(count) + " of " +
                         std::to_string(params_.min_consistent_queries) + " queries in a streak";
    } else if (accepted) {
      candidate.status = CandidateStatus::kNotYetConsistent;
      candidate.reason = "a better island was accepted by this query";
    } else {
      candidate.status = CandidateStatus::kAccepted;
      accepted = true;
      loops_.push_back(AcceptedLoop{query_id, query_position, island.best});
    }
  }
  // The earlier streaks the next query may still extend stay, beside this query's.
  for (const ConsistencyGroup& group : groups_) {
    if (group.query < query_position && query_position <= group.query + missed) {
      groups.push_back(group);
    }
  }
  groups_ = std::move(groups);
}

}  // namespace scale_drift_slam::loop
