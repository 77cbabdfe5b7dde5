#pragma once
// A vocabulary of binary visual words: a hierarchical k-majority tree over 256-bit ORB
// descriptors with tf-idf word weights (D. Galvez-Lopez, J. D. Tardos, "Bags of Binary Words for
// Fast Place Recognition in Image Sequences", T-RO 2012; the DBoW2 scheme). Learned from the
// keyframes themselves (online) or loaded from a small file. Immutable once built: share it
// between threads as std::shared_ptr<const Vocabulary>.

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "scale_drift_slam/loop/place_recognition_params.h"

namespace scale_drift_slam::loop {

using WordId = std::uint32_t;
using NodeId = std::uint32_t;

/// A bag of words: the words present in an image with their tf-idf weights, sorted by word and
/// normalised to sum 1 (L1). Words whose idf is 0 (present in every training image) are dropped.
struct BowVector {
  std::vector<WordId> words;
  std::vector<float> weights;

  std::size_t size() const { return words.size(); }
  bool empty() const { return words.empty(); }
};

/// Keypoint indices grouped by the vocabulary node a few levels above their word (DBoW2's
/// "direct index"): matching only compares keypoints of the same group. Sorted by node.
struct FeatureGroups {
  std::vector<NodeId> nodes;
  std::vector<std::vector<int>> features;
};

class Vocabulary {
 public:
  /// An empty vocabulary (no words); transform() throws on it.
  Vocabulary() = default;

  /// Learns the tree from descriptors (CV_8UC1, n x 32, one matrix per training image): k-means++
  /// seeding and k-majority refinement per node, top-down (DBoW2's HKmeansStep). The idf of word
  /// w is log(N / n_w) over the N training images, n_w of them holding w. Deterministic for a
  /// given seed. Throws std::invalid_argument for bad params, a wrong descriptor type or no
  /// descriptor at all.
  static Vocabulary train(const std::vector<cv::Mat>& descriptors_per_image,
                          const VocabularyParams& params);

  /// Reads a file written by save(). Throws std::runtime_error naming the file and the problem
  /// (missing, truncated, not a vocabulary, corrupted checksum, inconsistent tree).
  static Vocabulary load(const std::string& path);
  /// Writes a compact binary file (about 46 bytes per node). Throws std::runtime_error.
  void save(const std::string& path) const;
  /// The file's bytes (what save() writes), e.g. to embed the vocabulary in a map file.
  std::string toBytes() const;
  /// Parses toBytes() output; `origin` names the source in errors. Throws as load() does.
  static Vocabulary fromBytes(const std::string& data, const std::string& origin);

  bool empty() const { return idf_.empty(); }
  std::size_t numWords() const { return idf_.size(); }
  std::size_t numNodes() const { return first_child_.size(); }
  int branching() const { return branching_; }
  int depth() const { return depth_; }
  float idf(WordId word) const { return idf_.at(word); }

  /// The word of a descriptor: descend from the root to the nearest child (Hamming) at each
  /// level. With `group`, also returns the node on its path at level depth() - group_levels_up
  /// (the root is level 0; a word above that level is its own group).
  WordId word(const std::uint8_t* descriptor, NodeId* group = nullptr,
              int group_levels_up = 0) const;
  /// The bag of words of an image's descriptors (CV_8UC1, n x 32). Throws std::invalid_argument
  /// on a wrong descriptor matrix, std::logic_error on an empty vocabulary.
  BowVector transform(const cv::Mat& descriptors) const;
  /// The same, and the keypoints grouped for matching (FeatureGroups).
  BowVector transform(const cv::Mat& descriptors, FeatureGroups& groups, int group_levels_up) const;

 private:
  friend class VocabularyBuilder;
  static constexpr WordId kNoWord = 0xffffffffu;

  int branching_ = 0;
  int depth_ = 0;
  // Node i (0 is the root): its centre is row i of centres_; its children are the nodes
  // [first_child_[i], first_child_[i] + num_children_[i]); a node without children is the leaf
  // of word word_of_node_[i].
  cv::Mat centres_;
  std::vector<std::uint32_t> first_child_;
  std::vector<std::uint16_t> num_children_;
  std::vector<WordId> word_of_node_;
  std::vector<float> idf_;  ///< Per word.

  void checkConsistency(const std::string& origin) const;
};

}  // namespace scale_drift_slam::loop
