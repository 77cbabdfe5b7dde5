// Vocabulary::train: the hierarchical k-majority tree of DBoW2 (Galvez-Lopez & Tardos 2012,
// section III): the training descriptors are clustered into `branching` groups by k-means++
// seeding and k-majority refinement (the centre of binary descriptors is their bitwise majority,
// the median in Hamming space), and each group is split again, down to `depth` levels. The
// leaves are the words; idf(w) = log(N / n_w) over the N training images.

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <random>
#include <stdexcept>

#include "scale_drift_slam/loop/appearance.h"
#include "scale_drift_slam/loop/vocabulary.h"

namespace scale_drift_slam::loop {

using Descriptor = std::array<std::uint8_t, kDescriptorBytes>;

/// Builds one Vocabulary; lives for one call of Vocabulary::train.
class VocabularyBuilder {
 public:
  VocabularyBuilder(const VocabularyParams& params, const cv::Mat& data)
      : params_(params), data_(data), rng_(params.seed) {}

  Vocabulary build(const std::vector<int>& members) {
    vocabulary_.branching_ = params_.branching;
    vocabulary_.depth_ = params_.depth;
    addNode(Descriptor{});
    split(0, members, 0);
    vocabulary_.centres_ = cv::Mat(static_cast<int>(centres_.size()), kDescriptorBytes, CV_8UC1);
    for (std::size_t i = 0; i < centres_.size(); ++i) {
      std::copy(centres_[i].begin(), centres_[i].end(),
                vocabulary_.centres_.ptr<std::uint8_t>(static_cast<int>(i)));
    }
    vocabulary_.idf_.assign(num_words_, 0.0f);
    return std::move(vocabulary_);
  }

 private:
  const std::uint8_t* row(int i) const { return data_.ptr<std::uint8_t>(i); }

  NodeId addNode(const Descriptor& centre) {
    centres_.push_back(centre);
    vocabulary_.first_child_.push_back(0);
    vocabulary_.num_children_.push_back(0);
    vocabulary_.word_of_node_.push_back(Vocabulary::kNoWord);
    return static_cast<NodeId>(centres_.size() - 1);
  }

  void split(NodeId node, const std::vector<int>& members, int level) {
    std::vector<std::vector<int>> clusters;
    std::vector<Descriptor> centres;
    if (level < params_.depth && members.size() > 1) cluster(members, clusters, centres);
    if (clusters.size() <= 1) {  // the bottom, or all members alike: a word
      vocabulary_.word_of_node_[node] = static_cast<WordId>(num_words_++);
      return;
    }
    const NodeId first = static_cast<NodeId>(centres_.size());
    for (const Descriptor& centre : centres)
      addNode(centre);
    vocabulary_.first_child_[node] = first;
    vocabulary_.num_children_[node] = static_cast<std::uint16_t>(centres.size());
    for (std::size_t c = 0; c < clusters.size(); ++c) {
      split(first + static_cast<NodeId>(c), clusters[c], level + 1);
    }
  }

  /// Greedy k-means++ seeding (Arthur & Vassilvitskii 2007, with the local trials of
  /// scikit-learn): each new centre is the best, by the summed squared Hamming distance of the
  /// members to their nearest centre, of 2 + ln(k) members drawn with probability D^2.
  std::vector<Descriptor> seed(const std::vector<int>& members) {
    const auto descriptorOf = [&](std::size_t i) {
      Descriptor d;
      std::copy(row(members[i]), row(members[i]) + kDescriptorBytes, d.begin());
      return d;
    };
    const auto withCentre = [&](const std::vector<double>& nearest, const Descriptor& centre,
                                std::vector<double>& updated) {
      double total = 0.0;
      updated.resize(nearest.size());
      for (std::size_t i = 0; i < members.size(); ++i) {
        const double d = hammingDistance(row(members[i]), centre.data());
        updated[i] = std::min(nearest[i], d * d);
        total += updated[i];
      }
      return total;
    };
    const int trials = 2 + static_cast<int>(std::log(static_cast<double>(params_.branching)));
    std::uniform_int_distribution<std::size_t> pick_any(0, members.size() - 1);
    std::vector<Descriptor> centres{descriptorOf(pick_any(rng_))};
    std::vector<double> nearest(members.size(), 1e300);
    std::vector<double> trial_nearest;
    double total = withCentre(std::vector<double>(nearest), centres[0], nearest);
    while (static_cast<int>(centres.size()) < params_.branching && total > 0.0) {
      Descriptor best_centre{};
      std::vector<double> best_nearest;
      double best_total = -1.0;
      for (int trial = 0; trial < trials; ++trial) {
        double target = std::uniform_real_distribution<double>(0.0, total)(rng_);
        std::size_t chosen = members.size() - 1;
        for (std::size_t i = 0; i < members.size(); ++i) {
          target -= nearest[i];
          if (target <= 0.0 && nearest[i] > 0.0) {
            chosen = i;
            break;
          }
        }
        const Descriptor candidate = descriptorOf(chosen);
        const double candidate_total = withCentre(nearest, candidate, trial_nearest);
        if (best_total < 0.0 || candidate_total < best_total) {
          best_total = candidate_total;
          best_centre = candidate;
          best_nearest.swap(trial_nearest);
        }
      }
      centres.push_back(best_centre);
      nearest.swap(best_nearest);
      total = best_total;
    }
    return centres;
  }

  Descriptor majority(const std::vector<int>& cluster) const {
    std::array<int, std::size_t{8} * kDescriptorBytes> ones{};
    for (int member : cluster) {
      const std::uint8_t* d = row(member);
      for (int b = 0; b < kDescriptorBytes; ++b) {
        for (int bit = 0; bit < 8; ++bit)
          ones[8 * b + bit] += (d[b] >> bit) & 1;
      }
    }
    Descriptor centre{};
    for (int b = 0; b < kDescriptorBytes; ++b) {
      for (int bit = 0; bit < 8; ++bit) {
        if (2 * ones[8 * b + bit] > static_cast<int>(cluster.size())) centre[b] |= (1u << bit);
      }
    }
    return centre;
  }

  /// k-majority: assign to the nearest centre, move each centre to its cluster's majority, until
  /// the assignment stops changing. Empty clusters are dropped.
  void cluster(const std::vector<int>& members, std::vector<std::vector<int>>& clusters,
               std::vector<Descriptor>& centres) {
    centres = seed(members);
    std::vector<int> assignment(members.size(), -1);
    for (int iteration = 0; iteration < params_.max_iterations; ++iteration) {
      bool changed = false;
      for (std::size_t i = 0; i < members.size(); ++i) {
        int best = 0;
        int best_distance = 1 << 20;
        for (std::size_t c = 0; c < centres.size(); ++c) {
          const int d = hammingDistance(row(members[i]), centres[c].data());
          if (d < best_distance) {
            best_distance = d;
            best = static_cast<int>(c);
          }
        }
        changed |= assignment[i] != best;
        assignment[i] = best;
      }
      clusters.assign(centres.size(), {});
      for (std::size_t i = 0; i < members.size(); ++i)
        clusters[assignment[i]].push_back(members[i]);
      if (!changed) break;
      for (std::size_t c = 0; c < centres.size(); ++c) {
        if (!clusters[c].empty()) centres[c] = majority(clusters[c]);
      }
    }
    // Drop empty clusters (k-means++ never seeds two equal centres, but refinement may empty one).
    std::vector<std::vector<int>> kept_clusters;
    std::vector<Descriptor> kept_centres;
    for (std::size_t c = 0; c < clusters.size(); ++c) {
      if (clusters[c].empty()) continue;
      kept_clusters.push_back(std::move(clusters[c]));
      kept_centres.push_back(centres[c]);
    }
    clusters = std::move(kept_clusters);
    centres = std::move(kept_centres);
  }

  const VocabularyParams& params_;
  const cv::Mat& data_;
  std::mt19937 rng_;
  Vocabulary vocabulary_;
  std::vector<Descriptor> centres_;
  std::size_t num_words_ = 0;
};

Vocabulary Vocabulary::train(const std::vector<cv::Mat>& descriptors_per_image,
                             const VocabularyParams& params) {
  params.validate();
  std::vector<cv::Mat> images;
  for (const cv::Mat& descriptors : descriptors_per_image) {
    if (descriptors.empty()) continue;
    if (descriptors.type() != CV_8UC1 || descriptors.cols != kDescriptorBytes) {
      throw std::invalid_argument(
          "vocabulary training: descriptors must be CV_8UC1 with 32 columns");
    }
    images.push_back(descriptors);
  }
  if (images.empty()) throw std::invalid_argument("vocabulary training: no descriptors");
  cv::Mat all;
  cv::vconcat(images, all);
  std::vector<int> members(static_cast<std::size_t>(all.rows));
  std::iota(members.begin(), members.end(), 0);
  if (all.rows > params.max_training_descriptors) {  // a random subset, deterministic by seed
    std::mt19937 rng(params.seed + 1);
    std::shuffle(members.begin(), members.end(), rng);
    members.resize(static_cast<std::size_t>(params.max_training_descriptors));
    std::sort(members.begin(), members.end());
  }
  Vocabulary vocabulary = VocabularyBuilder(params, all).build(members);

  // idf(w) = log(N / n_w), n_w = training images holding w (at least 1: a word unseen after
  // subsampling gets the largest weight).
  std::vector<int> images_with_word(vocabulary.numWords(), 0);
  std::vector<int> last_image(vocabulary.numWords(), -1);
  for (std::size_t i = 0; i < images.size(); ++i) {
    for (int r = 0; r < images[i].rows; ++r) {
      const WordId w = vocabulary.word(images[i].ptr<std::uint8_t>(r));
      if (last_image[w] == static_cast<int>(i)) continue;
      last_image[w] = static_cast<int>(i);
      ++images_with_word[w];
    }
  }
  const double n = static_cast<double>(images.size());
  for (std::size_t w = 0; w < vocabulary.numWords(); ++w) {
    vocabulary.idf_[w] = static_cast<float>(std::log(n / std::max(1, images_with_word[w])));
  }
  return vocabulary;
}

}  // namespace scale_drift_slam::loop
