// PlaceRecognizer on synthetic walks with ground truth (synthetic_views.h): a revisit is found
// once and at the right place, walks without a revisit and an identical poster in two places
// give no loop, and the consistency, exclusion, continuation and online-vocabulary rules hold.

#include <gtest/gtest.h>

#include <algorithm>
#include <map>

#include "scale_drift_slam/loop/place_recognizer.h"
#include "synthetic_views.h"

namespace scale_drift_slam::loop {
namespace {

using testing::SyntheticKeyframe;
using testing::ViewPose;

/// A walk rendered and described once: keyframe i is walk[i] with appearance[i].
struct Walk {
  std::vector<SyntheticKeyframe> keyframes;
  std::vector<KeyframeAppearance> appearances;
  std::size_t first_revisit = 0;  ///< Keyframes from here on revisit wall 0 (if any).
};

Walk render(const std::vector<cv::Mat>& walls, std::vector<SyntheticKeyframe> keyframes) {
  Walk walk;
  AppearanceExtractor extractor{AppearanceParams{}};
  for (std::size_t i = 0; i < keyframes.size(); ++i) {
    const cv::Mat image = testing::renderView(walls[static_cast<std::size_t>(keyframes[i].wall)],
                                              keyframes[i].pose, 1000 + static_cast<int>(i));
    walk.appearances.push_back(extractor.extract(image));
  }
  walk.keyframes = std::move(keyframes);
  walk.first_revisit = walk.keyframes.size();
  return walk;
}

ViewPose revisitPose() {  // the same wall seen again, a little lower, rotated, zoomed, darker
  ViewPose pose;
  pose.y = 420;
  pose.angle_deg = -4.0;
  pose.scale = 1.08;
  pose.tilt_x = 1e-4;
  pose.gain = 0.85;
  pose.bias = 15.0;
  return pose;
}

/// Walls 0 and 1 walked once each (34 keyframes each, 120 px apart), then wall 0 again.
const Walk& revisitWalk() {
  static const Walk walk = [] {
    const std::vector<cv::Mat> walls = {testing::makeTexture(4800, 900, 31),
                                        testing::makeTexture(4800, 900, 32)};
    ViewPose base;
    base.y = 450;
    std::vector<SyntheticKeyframe> keyframes = testing::walkAlong(0, 400, 4400, 120, base);
    const auto second = testing::walkAlong(1, 400, 4400, 120, base);
    keyframes.insert(keyframes.end(), second.begin(), second.end());
    const std::size_t first_revisit = keyframes.size();
    const auto again = testing::walkAlong(0, 460, 2800, 120, revisitPose());
    keyframes.insert(keyframes.end(), again.begin(), again.end());
    Walk rendered = render(walls, keyframes);
    rendered.first_revisit = first_revisit;
    return rendered;
  }();
  return walk;
}

struct Outcome {
  std::vector<std::pair<std::size_t, map::KeyframeId>> accepted;  ///< (query, match) pairs.
  std::vector<PlaceQueryResult> results;
};

Outcome run(PlaceRecognizer& recognizer, const Walk& walk, std::size_t count = 0) {
  Outcome outcome;
  const std::size_t n = count == 0 ? walk.keyframes.size() : count;
  for (std::size_t i = 0; i < n; ++i) {
    outcome.results.push_back(
        recognizer.queryAndAdd(static_cast<map::KeyframeId>(i), 0.5 * i, walk.appearances[i]));
    if (const LoopCandidate* loop = outcome.results.back().accepted()) {
      outcome.accepted.emplace_back(i, loop->keyframe_id);
    }
  }
  return outcome;
}

TEST(PlaceRecognizer, FindsTheRevisitOnceAtTheRightPlace) {
  const Walk& walk = revisitWalk();
  PlaceRecognizer recognizer{PlaceRecognitionParams{}};
  const Outcome outcome = run(recognizer, walk);
  ASSERT_EQ(outcome.accepted.size(), 1u);
  const auto [query, match] = outcome.accepted.front();
  EXPECT_TRUE(testing::samePlace(walk.keyframes[query], walk.keyframes[match]))
      << "query " << query << " matched keyframe " << match;
  // Three consecutive verified queries are needed: the earliest is the third revisit keyframe.
  EXPECT_GE(query, walk.first_revisit + 2);
  EXPECT_LE(query, walk.first_revisit + 5);
  // Most revisit queries after the loop see the old place again, but only continue the loop.
  int continued = 0;
  for (std::size_t i = query + 1; i < walk.keyframes.size(); ++i) {
    for (const LoopCandidate& candidate : outcome.results[i].candidates) {
      if (candidate.status == CandidateStatus::kContinuesLoop) {
        EXPECT_TRUE(testing::samePlace(walk.keyframes[i], walk.keyframes[candidate.keyframe_id]));
        ++continued;
      }
    }
  }
  EXPECT_GE(continued, static_cast<int>(walk.keyframes.size() - query - 1) - 2);
}

TEST(PlaceRecognizer, NoLoopWithoutARevisitForSeveralSeeds) {
  for (std::uint32_t seed : {41u, 42u, 43u}) {
    const std::vector<cv::Mat> walls = {testing::makeTexture(3600, 900, seed),
                                        testing::makeTexture(3600, 900, seed + 100),
                                        testing::makeTexture(3600, 900, seed + 200)};
    ViewPose base;
    base.y = 450;
    std::vector<SyntheticKeyframe> keyframes;
    for (int wall = 0; wall < 3; ++wall) {
      base.angle_deg = 2.0 * wall;
      const auto part = testing::walkAlong(wall, 400, 3200, 120, base);
      keyframes.insert(keyframes.end(), part.begin(), part.end());
    }
    PlaceRecognizer recognizer{PlaceRecognitionParams{}};
    const Outcome outcome = run(recognizer, render(walls, keyframes));
    EXPECT_TRUE(outcome.accepted.empty())
        << "seed " << seed << ": false loop at query " << outcome.accepted.front().first;
  }
}

TEST(PlaceRecognizer, TheSamePosterInTwoPlacesIsNoLoop) {
  const cv::Mat poster = testing::makeTexture(320, 240, 77);
  std::vector<cv::Mat> walls = {testing::makeTexture(3000, 900, 51),
                                testing::makeTexture(3000, 900, 52)};
  testing::pastePoster(walls[0], poster, cv::Point(1400, 330));
  testing::pastePoster(walls[1], poster, cv::Point(1500, 290));
  ViewPose base;
  base.y = 450;
  std::vector<SyntheticKeyframe> keyframes = testing::walkAlong(0, 400, 2600, 100, base);
  const std::size_t first_b = keyframes.size();
  base.angle_deg = 3.0;
  const auto part = testing::walkAlong(1, 400, 2600, 100, base);
  keyframes.insert(keyframes.end(), part.begin(), part.end());
  PlaceRecognitionParams params;
  params.recent_keyframes_excluded = 10;  // so that wall A is searchable while on wall B
  PlaceRecognizer recognizer(params);
  const Walk walk = render(walls, keyframes);
  const Outcome outcome = run(recognizer, walk);
  EXPECT_TRUE(outcome.accepted.empty());
  // The poster does bring wall A's poster keyframes up as candidates; geometry refuses them.
  int refused_poster_candidates = 0;
  for (std::size_t i = first_b; i < walk.keyframes.size(); ++i) {
    for (const LoopCandidate& candidate : outcome.results[i].candidates) {
      const double x = walk.keyframes[candidate.keyframe_id].pose.x;
      if (walk.keyframes[candidate.keyframe_id].wall == 0 && std::abs(x - 1560) < 320 &&
          candidate.geometry.inliers >= params.geometry.min_inliers) {
        EXPECT_EQ(candidate.status, CandidateStatus::kFailedGeometry);
        ++refused_poster_candidates;
      }
    }
  }
  EXPECT_GE(refused_poster_candidates, 3);
}

TEST(PlaceRecognizer, AStreakOfVerifiedQueriesPassesOverAFewMisses) {
  const Walk& walk = revisitWalk();
  const std::size_t r = walk.first_revisit;
  // The revisit with `unrelated` keyframes of wall 1 (too recent to be proposed: they verify
  // nothing) queried between its second and third keyframe.
  const auto acceptedAt = [&](int needed, int max_missed, std::size_t unrelated) {
    std::vector<std::size_t> order;
    for (std::size_t i = 0; i < r; ++i)
      order.push_back(i);
    order.push_back(r);
    order.push_back(r + 1);
    for (std::size_t k = 0; k < unrelated; ++k)
      order.push_back(50 + k);
    for (std::size_t i = r + 2; i <= r + 5; ++i)
      order.push_back(i);
    PlaceRecognitionParams params;
    params.min_consistent_queries = needed;
    params.consistency_max_missed = max_missed;
    PlaceRecognizer recognizer(params);
    std::vector<std::size_t> accepted_at;
    for (std::size_t k = 0; k < order.size(); ++k) {
      const PlaceQueryResult result = recognizer.queryAndAdd(static_cast<map::KeyframeId>(k),
                                                             0.5 * k, walk.appearances[order[k]]);
      if (result.accepted() != nullptr) accepted_at.push_back(order[k]);
    }
    return accepted_at;
  };
  using Accepted = std::vector<std::size_t>;
  EXPECT_EQ(acceptedAt(1, 0, 1), Accepted{r});
  // Strictly consecutive: the unrelated query ends the streak, three more are needed.
  EXPECT_EQ(acceptedAt(3, 0, 1), Accepted{r + 4});
  // One miss passed over: the third verified query is the third of the streak.
  EXPECT_EQ(acceptedAt(3, 1, 1), Accepted{r + 2});
  // Two misses are one too many for max_missed 1, not for the default 2.
  EXPECT_EQ(acceptedAt(3, 1, 2), Accepted{r + 4});
  EXPECT_EQ(acceptedAt(3, PlaceRecognitionParams{}.consistency_max_missed, 2), Accepted{r + 2});
}

TEST(PlaceRecognizer, RecentAndExcludedKeyframesAreNotProposed) {
  const Walk& walk = revisitWalk();
  const auto last = static_cast<map::KeyframeId>(34);  // wall 0 only: keyframes 0..33
  const auto proposed = [&](const PlaceRecognitionParams& params,
                            const std::unordered_set<map::KeyframeId>& excluded) {
    PlaceRecognizer recognizer(params);
    for (map::KeyframeId i = 0; i < last; ++i)
      recognizer.add(i, 0.5 * i, walk.appearances[i]);
    // Keyframe 30 seen again.
    const PlaceQueryResult result =
        recognizer.query(1000, 0.5 * last, walk.appearances[30], excluded);
    std::set<map::KeyframeId> ids;
    for (const LoopCandidate& c : result.candidates) {
      for (map::KeyframeId id = c.island_first_id; id <= c.island_last_id; ++id)
        ids.insert(id);
    }
    return ids;
  };
  PlaceRecognitionParams params;
  params.recent_keyframes_excluded = 2;
  EXPECT_EQ(proposed(params, {}).count(30), 1u);
  EXPECT_EQ(proposed(params, {29, 30, 31}).count(30), 0u);
  params.recent_keyframes_excluded = 30;  // only keyframes 0..3 are old enough
  const std::set<map::KeyframeId> old_only = proposed(params, {});
  EXPECT_TRUE(old_only.empty() || *old_only.rbegin() <= 3);
  params.recent_keyframes_excluded = 2;
  params.recent_seconds_excluded = 10.0;  // query at t = 17: keyframes after t = 7 (id 14)
  const std::set<map::KeyframeId> by_time = proposed(params, {});
  EXPECT_TRUE(by_time.empty() || *by_time.rbegin() <= 14);
}

TEST(PlaceRecognizer, AForgottenKeyframeIsNeverProposedAgain) {
  const Walk& walk = revisitWalk();
  for (const bool before_vocabulary : {false, true}) {
    PlaceRecognitionParams params;
    params.recent_keyframes_excluded = 2;
    params.online_training_keyframes = 20;
    PlaceRecognizer recognizer(params);
    for (map::KeyframeId i = 0; i < 34; ++i) {
      recognizer.add(i, 0.5 * i, walk.appearances[i]);
      // Culled while the vocabulary is still learned from the first 20: it keeps its features
      // until then (the learning needs them), and is left out all the same.
      if (before_vocabulary && i == 12) {
        for (map::KeyframeId k = 9; k <= 11; ++k)
          recognizer.forget(k);
      }
    }
    if (!before_vocabulary) {
      for (map::KeyframeId k = 9; k <= 11; ++k)
        recognizer.forget(k);
    }
    recognizer.forget(999);  // unknown: ignored
    ASSERT_TRUE(recognizer.vocabularyReady());
    EXPECT_FALSE(recognizer.contains(10));
    EXPECT_THROW(recognizer.appearance(10), std::out_of_range);
    EXPECT_EQ(recognizer.places().size(), 31u);
    // Keyframe 10 seen again: its neighbours are proposed, never 9..11.
    const PlaceQueryResult result = recognizer.query(1000, 17.0, walk.appearances[10]);
    ASSERT_FALSE(result.candidates.empty());
    for (const LoopCandidate& c : result.candidates)
      EXPECT_TRUE(c.keyframe_id < 9 || c.keyframe_id > 11) << c.keyframe_id;
    const std::vector<LoopCandidate> places =
        recognizer.findPlaces(walk.appearances[10], 5, GeometricCheckParams{});
    ASSERT_FALSE(places.empty());
    for (const LoopCandidate& c : places)
      EXPECT_TRUE(c.keyframe_id < 9 || c.keyframe_id > 11) << c.keyframe_id;
    EXPECT_EQ(recognizer.appearance(12).size(), walk.appearances[12].size());
  }
}

TEST(PlaceRecognizer, ARejectedLoopNoLongerSuppressesItsContinuation) {
  const Walk& walk = revisitWalk();
  PlaceRecognizer recognizer{PlaceRecognitionParams{}};
  std::vector<std::size_t> accepted_at;
  for (std::size_t i = 0; i < walk.keyframes.size() && accepted_at.size() < 2; ++i) {
    const PlaceQueryResult result =
        recognizer.queryAndAdd(static_cast<map::KeyframeId>(i), 0.5 * i, walk.appearances[i]);
    if (result.accepted() != nullptr) {
      accepted_at.push_back(i);
      recognizer.reportLoopRejected(static_cast<map::KeyframeId>(i));  // metric check failed
    }
  }
  ASSERT_EQ(accepted_at.size(), 2u);
  EXPECT_EQ(accepted_at[1], accepted_at[0] + 1);
}

TEST(PlaceRecognizer, OnlineVocabularyIsLearnedAfterTheFirstKeyframes) {
  const Walk& walk = revisitWalk();
  PlaceRecognitionParams params;
  params.online_training_keyframes = 10;
  PlaceRecognizer recognizer(params);
  for (map::KeyframeId i = 0; i < 10; ++i) {
    EXPECT_FALSE(recognizer.vocabularyReady());
    const PlaceQueryResult result = recognizer.queryAndAdd(i, 0.5 * i, walk.appearances[i]);
    EXPECT_FALSE(result.searched);
    EXPECT_NE(result.skip_reason.find("vocabulary"), std::string::npos);
  }
  ASSERT_TRUE(recognizer.vocabularyReady());
  EXPECT_GT(recognizer.vocabulary()->numWords(), 1000u);
  EXPECT_TRUE(recognizer.queryAndAdd(10, 5.0, walk.appearances[10]).searched);
  EXPECT_EQ(recognizer.size(), 11u);
  EXPECT_EQ(recognizer.appearance(3).size(), walk.appearances[3].size());
  EXPECT_THROW(recognizer.add(3, 9.0, walk.appearances[3]), std::invalid_argument);
  EXPECT_THROW(recognizer.appearance(99), std::out_of_range);
}

TEST(PlaceRecognizer, BeforeTheVocabularyRelocalisationMatchesTheNewestKeyframes) {
  // A young map (no vocabulary yet): a lost camera back on wall 0 between keyframes 4 and 5 is
  // matched against the newest keyframes by brute force; a view of another wall passes none.
  const Walk& walk = revisitWalk();
  PlaceRecognizer recognizer{PlaceRecognitionParams{}};
  for (map::KeyframeId i = 0; i < 8; ++i)
    recognizer.add(i, 0.5 * i, walk.appearances[i]);
  recognizer.forget(6);
  ASSERT_FALSE(recognizer.vocabularyReady());
  const std::vector<LoopCandidate> places =
      recognizer.findPlaces(walk.appearances[walk.first_revisit + 4], 4, GeometricCheckParams{});
  std::vector<map::KeyframeId> proposed, passed;
  for (const LoopCandidate& c : places) {
    proposed.push_back(c.keyframe_id);
    if (c.geometry.passed) passed.push_back(c.keyframe_id);
    EXPECT_EQ(c.geometry.passed, c.status == CandidateStatus::kAccepted);
  }
  EXPECT_EQ(proposed, (std::vector<map::KeyframeId>{7, 5, 4, 3}));
  // The two keyframes nearest the view (60 px on either side of it) pass.
  EXPECT_NE(std::find(passed.begin(), passed.end(), 4), passed.end());
  EXPECT_NE(std::find(passed.begin(), passed.end(), 5), passed.end());
  for (const LoopCandidate& c :
       recognizer.findPlaces(walk.appearances[40], 4, GeometricCheckParams{})) {
    EXPECT_FALSE(c.geometry.passed) << c.keyframe_id;
  }
  EXPECT_TRUE(PlaceRecognizer{PlaceRecognitionParams{}}
                  .findPlaces(walk.appearances[0], 4, GeometricCheckParams{})
                  .empty());
}

TEST(PlaceRecognizer, AVocabularyFileIsUsedFromTheFirstKeyframe) {
  const Walk& walk = revisitWalk();
  std::vector<cv::Mat> training;
  for (std::size_t i = 34; i < 54; ++i)
    training.push_back(walk.appearances[i].descriptors);
  PlaceRecognitionParams params;
  const std::string path = std::string(SDS_TEST_OUTPUT_DIR) + "/test_place_vocabulary.bin";
  Vocabulary::train(training, params.vocabulary).save(path);
  params.vocabulary_file = path;
  PlaceRecognizer recognizer(params);
  EXPECT_TRUE(recognizer.vocabularyReady());
  const Outcome outcome = run(recognizer, walk);
  ASSERT_EQ(outcome.accepted.size(), 1u);
  EXPECT_TRUE(testing::samePlace(walk.keyframes[outcome.accepted[0].first],
                                 walk.keyframes[outcome.accepted[0].second]));
  params.vocabulary_file = std::string(SDS_TEST_OUTPUT_DIR) + "/missing_vocabulary.bin";
  EXPECT_THROW(PlaceRecognizer{params}, std::runtime_error);
}

TEST(PlaceRecognitionParams, ValidateNamesTheBadField) {
  PlaceRecognitionParams params;
  EXPECT_NO_THROW(params.validate());
  const auto message = [](const PlaceRecognitionParams& p) {
    try {
      p.validate();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  PlaceRecognitionParams bad = params;
  bad.min_consistent_queries = 0;
  EXPECT_NE(message(bad).find("min_consistent_queries"), std::string::npos);
  bad = params;
  bad.consistency_max_missed = -1;
  EXPECT_NE(message(bad).find("consistency_max_missed"), std::string::npos);
  bad = params;
  bad.geometry.min_coverage = 1.5;
  EXPECT_NE(message(bad).find("min_coverage"), std::string::npos);
  bad = params;
  bad.vocabulary.depth = 0;
  EXPECT_NE(message(bad).find("depth"), std::string::npos);
  bad = params;
  bad.appearance.max_features = 5;
  EXPECT_NE(message(bad).find("max_features"), std::string::npos);
  bad = params;
  bad.recent_seconds_excluded = -1.0;
  EXPECT_THROW(PlaceRecognizer{bad}, std::invalid_argument);
}

}  // namespace
}  // namespace scale_drift_slam::loop
