// "Did you mean": the closest accepted key to a misspelt one, shared by every file parser.

#include <gtest/gtest.h>

#include "scale_drift_slam/io/key_suggestion.h"

namespace scale_drift_slam::io {
namespace {

TEST(KeySuggestion, EditDistanceCountsTranspositionsAsOne) {
  EXPECT_EQ(editDistance("distortion_modle", "distortion_model"), 1u);
  EXPECT_EQ(editDistance("fx", "fx"), 0u);
  EXPECT_EQ(editDistance("", "abc"), 3u);
  EXPECT_EQ(editDistance("kitten", "sitting"), 3u);
  EXPECT_EQ(editDistance("good_inlier", "good_inliers"), 1u);
}

TEST(KeySuggestion, SuggestsOnlyLikelyTypos) {
  const std::vector<std::string> keys = {"distortion_model", "distortion", "fx", "fy", "cx"};
  EXPECT_EQ(closestKey("distortion_modle", keys), "distortion_model");
  EXPECT_EQ(closestKey("distorsion", keys), "distortion");
  EXPECT_EQ(closestKey("FX", keys), "fx");
  EXPECT_EQ(closestKey("fz", keys), "fx");  // one edit; fx comes first of fx/fy
  EXPECT_EQ(closestKey("lens", keys), "");
  EXPECT_EQ(closestKey("model", keys), "");  // 11 edits from distortion_model
  EXPECT_EQ(closestKey(std::string(1000, 'x'), keys), "");
  EXPECT_EQ(unknownKeyMessage("key", "distortion_modle", keys),
            "unknown key 'distortion_modle' (did you mean 'distortion_model'?)");
  EXPECT_EQ(unknownKeyMessage("section", "lens", keys), "unknown section 'lens'");
  EXPECT_EQ(unknownKeyMessageSuggesting("key", "a.b", "c.b"),
            "unknown key 'a.b' (did you mean 'c.b'?)");
}

}  // namespace
}  // namespace scale_drift_slam::io
