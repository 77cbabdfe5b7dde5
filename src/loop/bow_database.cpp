#include "scale_drift_slam/loop/bow_database.h"

#include <algorithm>

namespace scale_drift_slam::loop {

std::size_t BowDatabase::add(const BowVector& bow) {
  const auto index = static_cast<std::uint32_t>(documents_.size());
  for (std::size_t i = 0; i < bow.size(); ++i) {
    const WordId w = bow.words[i];
    if (w >= postings_.size()) postings_.resize(static_cast<std::size_t>(w) + 1);
    postings_[w].push_back(Posting{index, bow.weights[i]});
  }
  documents_.push_back(bow);
  return index;
}

void BowDatabase::forget(std::size_t index) {
  if (index >= documents_.size()) return;
  const auto document = static_cast<std::uint32_t>(index);
  for (const WordId w : documents_[index].words) {
    // Postings are in document order: the document's one is found by bisection.
    std::vector<Posting>& postings = postings_[w];
    const auto it = std::lower_bound(
        postings.begin(), postings.end(), document,
        [](const Posting& posting, std::uint32_t d) { return posting.document < d; });
    if (it != postings.end() && it->document == document) postings.erase(it);
  }
  documents_[index] = BowVector{};
}

void BowDatabase::scoreAll(const BowVector& query, std::vector<float>& scores) const {
  scores.assign(documents_.size(), 0.0f);
  for (std::size_t i = 0; i < query.size(); ++i) {
    const WordId w = query.words[i];
    if (w >= postings_.size()) continue;
    const float q = query.weights[i];
    for (const Posting& posting : postings_[w]) {
      scores[posting.document] += std::min(q, posting.weight);
    }
  }
}

double BowDatabase::score(const BowVector& a, const BowVector& b) {
  double sum = 0.0;
  std::size_t i = 0;
  std::size_t j = 0;
  while (i < a.size() && j < b.size()) {
    if (a.words[i] < b.words[j]) {
      ++i;
    } else if (b.words[j] < a.words[i]) {
      ++j;
    } else {
      sum += std::min(a.weights[i], b.weights[j]);
      ++i;
      ++j;
    }
  }
  return sum;
}

}  // namespace scale_drift_slam::loop
