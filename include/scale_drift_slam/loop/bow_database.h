#pragma once
// The inverted index of place recognition: for every word, the keyframes (documents) holding it
// and their weights, so that a query touches only the documents sharing a word with it
// (DBoW2's database). Documents are numbered 0, 1, ... in insertion order. Single-threaded: owned
// by the PlaceRecognizer.

#include <cstdint>
#include <vector>

#include "scale_drift_slam/loop/vocabulary.h"

namespace scale_drift_slam::loop {

class BowDatabase {
 public:
  /// Adds a bag of words; returns its document number.
  std::size_t add(const BowVector& bow);
  /// Takes a document out of the index (its postings and bag go; its number stays, scoring 0).
  void forget(std::size_t index);
  std::size_t size() const { return documents_.size(); }
  const BowVector& document(std::size_t index) const { return documents_.at(index); }

  /// The L1 score of the query against every document, in document order:
  /// s(q, d) = 1 - |q - d|_1 / 2 for L1-normalised q and d (DBoW2, Galvez-Lopez & Tardos 2012,
  /// eq. 2), which for non-negative weights equals sum over common words of min(q_w, d_w): 1 for
  /// equal vectors, 0 without a common word. Only the postings of the query's words are visited.
  void scoreAll(const BowVector& query, std::vector<float>& scores) const;

  /// The same score between two bags of words (merge of the sorted words).
  static double score(const BowVector& a, const BowVector& b);

 private:
  struct Posting {
    std::uint32_t document;
    float weight;
  };
  std::vector<std::vector<Posting>> postings_;  ///< Indexed by word.
  std::vector<BowVector> documents_;
};

}  // namespace scale_drift_slam::loop
