#include "scale_drift_slam/loop/vocabulary.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <stdexcept>

#include "scale_drift_slam/loop/appearance.h"

namespace scale_drift_slam::loop {
namespace {

constexpr char kMagic[8] = {'S', 'D', 'S', 'V', 'O', 'C', '0', '1'};

void checkDescriptors(const cv::Mat& descriptors) {
  if (descriptors.empty()) return;
  if (descriptors.type() != CV_8UC1 || descriptors.cols != kDescriptorBytes) {
    throw std::invalid_argument("vocabulary: descriptors must be CV_8UC1 with 32 columns");
  }
}

/// FNV-1a, 64 bit: detects a corrupted or truncated file.
std::uint64_t fnv1a(const char* data, std::size_t size) {
  std::uint64_t hash = 1469598103934665603ull;
  for (std::size_t i = 0; i < size; ++i) {
    hash ^= static_cast<unsigned char>(data[i]);
    hash *= 1099511628211ull;
  }
  return hash;
}

template <typename T>
void append(std::string& out, const T* values, std::size_t count) {
  out.append(reinterpret_cast<const char*>(values), count * sizeof(T));
}

/// Reads consecutive arrays from a byte buffer, failing on a short buffer.
class Reader {
 public:
  Reader(const std::string& data, std::string origin) : data_(data), origin_(std::move(origin)) {}
  template <typename T>
  void read(T* values, std::size_t count) {
    const std::size_t bytes = count * sizeof(T);
    if (offset_ + bytes > data_.size()) fail("truncated");
    std::memcpy(values, data_.data() + offset_, bytes);
    offset_ += bytes;
  }
  std::size_t offset() const { return offset_; }
  [[noreturn]] void fail(const std::string& reason) const {
    throw std::runtime_error("vocabulary " + origin_ + ": " + reason);
  }

 private:
  const std::string& data_;
  std::string origin_;
  std::size_t offset_ = 0;
};

}  // namespace

SDS_HAMMING_LOOP
WordId Vocabulary::word(const std::uint8_t* descriptor, NodeId* group, int group_levels_up) const {
  if (empty()) throw std::logic_error("vocabulary: empty (not trained or loaded)");
  const int group_level = std::max(0, depth_ - group_levels_up);
  NodeId node = 0;
  NodeId group_node = 0;
  for (int level = 1; num_children_[node] > 0; ++level) {
    const NodeId first = first_child_[node];
    NodeId best = first;
    int best_distance = 1 << 20;
    for (NodeId child = first; child < first + num_children_[node]; ++child) {
      const int d =
          hammingDistance(descriptor, centres_.ptr<std::uint8_t>(static_cast<int>(child)));
      if (d < best_distance) {
        best_distance = d;
        best = child;
      }
    }
    node = best;
    if (level <= group_level) group_node = node;
  }
  if (group != nullptr) *group = group_node;
  return word_of_node_[node];
}

BowVector Vocabulary::transform(const cv::Mat& descriptors) const {
  FeatureGroups unused;
  return transform(descriptors, unused, 0);
}

BowVector Vocabulary::transform(const cv::Mat& descriptors, FeatureGroups& groups,
                                int group_levels_up) const {
  checkDescriptors(descriptors);
  if (empty()) throw std::logic_error("vocabulary: empty (not trained or loaded)");
  // tf-idf (DBoW2's TF_IDF): each occurrence of w adds idf(w); the tf denominator cancels in
  // the L1 normalisation below.
  std::vector<std::pair<WordId, float>> entries;
  std::vector<std::pair<NodeId, int>> grouped;
  entries.reserve(static_cast<std::size_t>(descriptors.rows));
  grouped.reserve(static_cast<std::size_t>(descriptors.rows));
  for (int i = 0; i < descriptors.rows; ++i) {
    NodeId group = 0;
    const WordId w = word(descriptors.ptr<std::uint8_t>(i), &group, group_levels_up);
    entries.emplace_back(w, idf_[w]);
    grouped.emplace_back(group, i);
  }
  std::sort(entries.begin(), entries.end());
  BowVector bow;
  double sum = 0.0;
  for (const auto& [w, weight] : entries) {
    if (weight <= 0.0f) continue;
    if (!bow.words.empty() && bow.words.back() == w) {
      bow.weights.back() += weight;
    } else {
      bow.words.push_back(w);
      bow.weights.push_back(weight);
    }
    sum += weight;
  }
  for (float& weight : bow.weights)
    weight = static_cast<float>(weight / sum);

  std::stable_sort(grouped.begin(), grouped.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  groups = FeatureGroups{};
  for (const auto& [node, feature] : grouped) {
    if (groups.nodes.empty() || groups.nodes.back() != node) {
      groups.nodes.push_back(node);
      groups.features.emplace_back();
    }
    groups.features.back().push_back(feature);
  }
  return bow;
}

std::string Vocabulary::toBytes() const {
  if (empty()) throw std::runtime_error("vocabulary: cannot save an empty vocabulary");
  std::string out(kMagic, sizeof(kMagic));
  const std::uint32_t header[5] = {
      static_cast<std::uint32_t>(branching_), static_cast<std::uint32_t>(depth_),
      static_cast<std::uint32_t>(numNodes()), static_cast<std::uint32_t>(numWords()),
      static_cast<std::uint32_t>(kDescriptorBytes)};
  append(out, header, 5);
  append(out, first_child_.data(), first_child_.size());
  append(out, num_children_.data(), num_children_.size());
  append(out, word_of_node_.data(), word_of_node_.size());
  append(out, centres_.ptr<std::uint8_t>(0), numNodes() * kDescriptorBytes);
  append(out, idf_.data(), idf_.size());
  const std::uint64_t checksum = fnv1a(out.data(), out.size());
  append(out, &checksum, 1);
  return out;
}

void Vocabulary::save(const std::string& path) const {
  const std::string out = toBytes();
  std::ofstream file(path, std::ios::binary);
  if (!file || !file.write(out.data(), static_cast<std::streamsize>(out.size()))) {
    throw std::runtime_error("vocabulary " + path + ": cannot write");
  }
}

Vocabulary Vocabulary::load(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) throw std::runtime_error("vocabulary " + path + ": cannot open");
  const std::string data((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  return fromBytes(data, path);
}

Vocabulary Vocabulary::fromBytes(const std::string& data, const std::string& origin) {
  Reader reader(data, origin);
  char magic[sizeof(kMagic)];
  reader.read(magic, sizeof(kMagic));
  if (std::memcmp(magic, kMagic, sizeof(kMagic)) != 0) reader.fail("not a vocabulary file");
  std::uint32_t header[5];
  reader.read(header, 5);
  const std::size_t nodes = header[2];
  const std::size_t words = header[3];
  if (header[4] != kDescriptorBytes) reader.fail("descriptors are not 32 bytes");
  if (nodes == 0 || nodes > 50000000 || words == 0 || words > nodes) {
    reader.fail("bad node or word count");
  }
  const std::size_t expected = sizeof(kMagic) + sizeof(header) + nodes * (4 + 2 + 4) +
                               nodes * kDescriptorBytes + words * 4 + 8;
  if (data.size() != expected) reader.fail("truncated or has trailing bytes");
  Vocabulary vocabulary;
  vocabulary.branching_ = static_cast<int>(header[0]);
  vocabulary.depth_ = static_cast<int>(header[1]);
  vocabulary.first_child_.resize(nodes);
  vocabulary.num_children_.resize(nodes);
  vocabulary.word_of_node_.resize(nodes);
  vocabulary.centres_ = cv::Mat(static_cast<int>(nodes), kDescriptorBytes, CV_8UC1);
  vocabulary.idf_.resize(words);
  reader.read(vocabulary.first_child_.data(), nodes);
  reader.read(vocabulary.num_children_.data(), nodes);
  reader.read(vocabulary.word_of_node_.data(), nodes);
  reader.read(vocabulary.centres_.ptr<std::uint8_t>(0), nodes * kDescriptorBytes);
  reader.read(vocabulary.idf_.data(), words);
  const std::size_t payload = reader.offset();
  std::uint64_t checksum = 0;
  reader.read(&checksum, 1);
  if (checksum != fnv1a(data.data(), payload)) reader.fail("checksum mismatch (corrupted)");
  vocabulary.checkConsistency(origin);
  return vocabulary;
}

void Vocabulary::checkConsistency(const std::string& origin) const {
  const auto fail = [&](const std::string& reason) {
    throw std::runtime_error("vocabulary " + origin + ": " + reason);
  };
  if (branching_ < 2 || branching_ > 64 || depth_ < 1 || depth_ > 8) fail("bad branching/depth");
  const std::size_t nodes = numNodes();
  std::vector<int> level(nodes, -1);
  std::vector<bool> word_seen(numWords(), false);
  level[0] = 0;
  for (std::size_t node = 0; node < nodes; ++node) {
    if (level[node] < 0) fail("node " + std::to_string(node) + " has no parent");
    if (num_children_[node] == 0) {
      const WordId w = word_of_node_[node];
      if (w >= numWords() || word_seen[w]) fail("leaf with a bad or repeated word");
      word_seen[w] = true;
      continue;
    }
    if (num_children_[node] > branching_ || level[node] >= depth_) fail("tree deeper or wider");
    if (first_child_[node] <= node || first_child_[node] + num_children_[node] > nodes) {
      fail("children out of order");
    }
    for (std::size_t c = first_child_[node]; c < first_child_[node] + num_children_[node]; ++c) {
      if (level[c] >= 0) fail("node with two parents");
      level[c] = level[node] + 1;
    }
  }
  if (std::find(word_seen.begin(), word_seen.end(), false) != word_seen.end()) {
    fail("a word without a leaf");
  }
  for (float w : idf_) {
    if (!std::isfinite(w) || w < 0.0f) fail("a negative or non-finite idf");
  }
}

}  // namespace scale_drift_slam::loop
