// The binary vocabulary and the inverted index against known answers: descriptors drawn around
// known centres fall into one word per centre, idf follows its definition, scores equal the L1
// formula, files round-trip and damaged files are refused.

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <random>

#include "scale_drift_slam/loop/appearance.h"
#include "scale_drift_slam/loop/bow_database.h"
#include "scale_drift_slam/loop/vocabulary.h"

namespace scale_drift_slam::loop {
namespace {

cv::Mat randomDescriptors(int rows, std::mt19937& rng) {
  cv::Mat descriptors(rows, kDescriptorBytes, CV_8UC1);
  std::uniform_int_distribution<int> byte(0, 255);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < kDescriptorBytes; ++c)
      descriptors.at<std::uint8_t>(r, c) = byte(rng);
  }
  return descriptors;
}

/// `per_centre` copies of each centre row with up to `flips` random bits flipped.
cv::Mat noisyCopies(const cv::Mat& centres, int per_centre, int flips, std::mt19937& rng) {
  cv::Mat out(centres.rows * per_centre, kDescriptorBytes, CV_8UC1);
  std::uniform_int_distribution<int> bit(0, 8 * kDescriptorBytes - 1);
  for (int c = 0; c < centres.rows; ++c) {
    for (int k = 0; k < per_centre; ++k) {
      cv::Mat row = out.row(c * per_centre + k);
      centres.row(c).copyTo(row);
      for (int f = 0; f < flips; ++f) {
        const int b = bit(rng);
        row.at<std::uint8_t>(0, b / 8) ^= static_cast<std::uint8_t>(1u << (b % 8));
      }
    }
  }
  return out;
}

std::string outputPath(const std::string& name) {
  return std::string(SDS_TEST_OUTPUT_DIR) + "/" + name;
}

TEST(Vocabulary, HammingDistanceEqualsOpenCvs) {
  std::mt19937 rng(1);
  const cv::Mat d = randomDescriptors(50, rng);
  for (int i = 0; i < d.rows; ++i) {
    for (int j = 0; j < d.rows; ++j) {
      EXPECT_EQ(hammingDistance(d.ptr<std::uint8_t>(i), d.ptr<std::uint8_t>(j)),
                static_cast<int>(cv::norm(d.row(i), d.row(j), cv::NORM_HAMMING)));
    }
  }
  EXPECT_EQ(bitCount(~0ull), 64);
  EXPECT_EQ(bitCount(0ull), 0);
}

TEST(Vocabulary, ClustersAroundKnownCentresBecomeOneWordEach) {
  std::mt19937 rng(3);
  const cv::Mat centres = randomDescriptors(8, rng);  // random centres are ~128 bits apart
  const cv::Mat training = noisyCopies(centres, 40, 10, rng);
  VocabularyParams params;
  params.branching = 8;
  params.depth = 1;
  const Vocabulary vocabulary = Vocabulary::train({training}, params);
  ASSERT_EQ(vocabulary.numWords(), 8u);
  std::set<WordId> words;
  for (int c = 0; c < centres.rows; ++c) {
    const WordId w = vocabulary.word(centres.ptr<std::uint8_t>(c));
    words.insert(w);
    const cv::Mat fresh = noisyCopies(centres.row(c), 20, 10, rng);  // unseen noisy copies
    for (int r = 0; r < fresh.rows; ++r)
      EXPECT_EQ(vocabulary.word(fresh.ptr<std::uint8_t>(r)), w);
  }
  EXPECT_EQ(words.size(), 8u);
}

TEST(Vocabulary, IdfIsLogOfImagesOverImagesHoldingTheWord) {
  std::mt19937 rng(5);
  const cv::Mat centres = randomDescriptors(4, rng);
  // Four training images: centre 0 in all of them, centre 1 in two, centres 2 and 3 in one each.
  std::vector<cv::Mat> images(4);
  const std::vector<std::vector<int>> holds = {{0, 1, 2}, {0, 1, 3}, {0}, {0}};
  for (std::size_t i = 0; i < images.size(); ++i) {
    for (int c : holds[i])
      images[i].push_back(noisyCopies(centres.row(c), 10, 4, rng));
  }
  VocabularyParams params;
  params.branching = 4;
  params.depth = 1;
  const Vocabulary vocabulary = Vocabulary::train(images, params);
  ASSERT_EQ(vocabulary.numWords(), 4u);
  const auto idf_of = [&](int c) {
    return vocabulary.idf(vocabulary.word(centres.ptr<std::uint8_t>(c)));
  };
  EXPECT_NEAR(idf_of(0), 0.0, 1e-6);
  EXPECT_NEAR(idf_of(1), std::log(2.0), 1e-6);
  EXPECT_NEAR(idf_of(2), std::log(4.0), 1e-6);
  EXPECT_NEAR(idf_of(3), std::log(4.0), 1e-6);

  // A bag of words drops the idf-0 word and is L1-normalised: centre 1 (idf log 2) twice and
  // centre 2 (idf log 4) once give weights 2 log2 : log4 = 1 : 1.
  cv::Mat query;
  query.push_back(centres.row(0));
  query.push_back(centres.row(1));
  query.push_back(centres.row(1));
  query.push_back(centres.row(2));
  const BowVector bow = vocabulary.transform(query);
  ASSERT_EQ(bow.size(), 2u);
  EXPECT_TRUE(std::is_sorted(bow.words.begin(), bow.words.end()));
  EXPECT_NEAR(bow.weights[0], 0.5, 1e-6);
  EXPECT_NEAR(bow.weights[1], 0.5, 1e-6);
}

TEST(Vocabulary, TrainingIsDeterministicAndSaveLoadRoundTrips) {
  std::mt19937 rng(7);
  std::vector<cv::Mat> images;
  images.reserve(6);
  for (int i = 0; i < 6; ++i)
    images.push_back(randomDescriptors(300, rng));
  VocabularyParams params;
  params.branching = 6;
  params.depth = 3;
  const Vocabulary a = Vocabulary::train(images, params);
  const Vocabulary b = Vocabulary::train(images, params);
  const std::string path = outputPath("test_vocabulary.bin");
  a.save(path);
  const Vocabulary loaded = Vocabulary::load(path);
  EXPECT_EQ(loaded.numWords(), a.numWords());
  EXPECT_EQ(loaded.numNodes(), a.numNodes());
  EXPECT_EQ(loaded.branching(), 6);
  EXPECT_EQ(loaded.depth(), 3);
  const cv::Mat probe = randomDescriptors(500, rng);
  for (int r = 0; r < probe.rows; ++r) {
    const WordId w = a.word(probe.ptr<std::uint8_t>(r));
    EXPECT_EQ(b.word(probe.ptr<std::uint8_t>(r)), w);
    EXPECT_EQ(loaded.word(probe.ptr<std::uint8_t>(r)), w);
    EXPECT_EQ(loaded.idf(w), a.idf(w));
  }
}

TEST(Vocabulary, RefusesDamagedMissingAndForeignFiles) {
  std::mt19937 rng(9);
  VocabularyParams params;
  params.branching = 4;
  params.depth = 2;
  const Vocabulary vocabulary = Vocabulary::train({randomDescriptors(200, rng)}, params);
  const std::string path = outputPath("test_vocabulary_damaged.bin");
  vocabulary.save(path);
  std::string bytes;
  {
    std::ifstream in(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  const auto write = [&](const std::string& content) {
    std::ofstream(path, std::ios::binary) << content;
  };
  std::string flipped = bytes;
  flipped[bytes.size() / 2] ^= 0x10;
  write(flipped);
  EXPECT_THROW(Vocabulary::load(path), std::runtime_error);
  write(bytes.substr(0, bytes.size() - 9));
  EXPECT_THROW(Vocabulary::load(path), std::runtime_error);
  write("not a vocabulary at all, just some text that is long enough");
  EXPECT_THROW(Vocabulary::load(path), std::runtime_error);
  EXPECT_THROW(Vocabulary::load(outputPath("no_such_vocabulary.bin")), std::runtime_error);
  write(bytes);
  EXPECT_NO_THROW(Vocabulary::load(path));
}

TEST(Vocabulary, RejectsBadInput) {
  VocabularyParams params;
  EXPECT_THROW(Vocabulary::train({}, params), std::invalid_argument);
  EXPECT_THROW(Vocabulary::train({cv::Mat(10, 16, CV_8UC1, cv::Scalar(0))}, params),
               std::invalid_argument);
  params.branching = 1;
  std::mt19937 rng(1);
  EXPECT_THROW(Vocabulary::train({randomDescriptors(50, rng)}, params), std::invalid_argument);
  EXPECT_THROW(Vocabulary().transform(randomDescriptors(5, rng)), std::logic_error);
}

TEST(BowDatabase, ScoresEqualOneMinusHalfTheL1Distance) {
  std::mt19937 rng(11);
  std::vector<cv::Mat> images;
  images.reserve(8);
  for (int i = 0; i < 8; ++i)
    images.push_back(randomDescriptors(200, rng));
  VocabularyParams params;
  params.branching = 5;
  params.depth = 3;
  const Vocabulary vocabulary = Vocabulary::train(images, params);
  BowDatabase database;
  std::vector<BowVector> bows;
  for (const cv::Mat& image : images) {
    bows.push_back(vocabulary.transform(image));
    EXPECT_EQ(database.add(bows.back()), bows.size() - 1);
  }
  // A query sharing half its descriptors with image 2.
  cv::Mat query = images[2].rowRange(0, 100).clone();
  query.push_back(randomDescriptors(100, rng));
  const BowVector q = vocabulary.transform(query);
  std::vector<float> scores;
  database.scoreAll(q, scores);
  ASSERT_EQ(scores.size(), bows.size());
  for (std::size_t d = 0; d < bows.size(); ++d) {
    std::vector<double> dense_q(vocabulary.numWords(), 0.0);
    std::vector<double> dense_d(vocabulary.numWords(), 0.0);
    for (std::size_t i = 0; i < q.size(); ++i)
      dense_q[q.words[i]] = q.weights[i];
    for (std::size_t i = 0; i < bows[d].size(); ++i)
      dense_d[bows[d].words[i]] = bows[d].weights[i];
    double l1 = 0.0;
    for (std::size_t w = 0; w < dense_q.size(); ++w)
      l1 += std::abs(dense_q[w] - dense_d[w]);
    EXPECT_NEAR(scores[d], 1.0 - 0.5 * l1, 1e-5);
    EXPECT_NEAR(BowDatabase::score(q, bows[d]), scores[d], 1e-5);
  }
  EXPECT_EQ(std::max_element(scores.begin(), scores.end()) - scores.begin(), 2);
  EXPECT_NEAR(BowDatabase::score(bows[3], bows[3]), 1.0, 1e-5);
}

}  // namespace
}  // namespace scale_drift_slam::loop
