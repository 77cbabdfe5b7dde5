// Place recognition params from YAML: the shipped file equals the compiled defaults, keys
// override, typos and bad values are refused with the key's name.

#include <gtest/gtest.h>

#include <fstream>

#include "scale_drift_slam/io/place_recognition_params_io.h"

namespace scale_drift_slam::io {
namespace {

std::string errorOf(const std::string& text) {
  try {
    parsePlaceRecognitionParams(text, "test");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(PlaceRecognitionParamsIo, ShippedFileHoldsTheDefaults) {
  const loop::PlaceRecognitionParams shipped = loadPlaceRecognitionParams(
      std::string(SDS_TEST_DATA_DIR) + "/../../config/place_recognition.yaml");
  const loop::PlaceRecognitionParams d;
  EXPECT_EQ(shipped.vocabulary_file, "");
  EXPECT_EQ(shipped.appearance.max_features, d.appearance.max_features);
  EXPECT_EQ(shipped.appearance.grid_cols, d.appearance.grid_cols);
  EXPECT_EQ(shipped.appearance.grid_rows, d.appearance.grid_rows);
  EXPECT_EQ(shipped.appearance.pyramid_levels, d.appearance.pyramid_levels);
  EXPECT_EQ(shipped.appearance.scale_factor, d.appearance.scale_factor);
  EXPECT_EQ(shipped.appearance.fast_threshold, d.appearance.fast_threshold);
  EXPECT_EQ(shipped.appearance.min_fast_threshold, d.appearance.min_fast_threshold);
  EXPECT_EQ(shipped.appearance.border, d.appearance.border);
  EXPECT_EQ(shipped.vocabulary.branching, d.vocabulary.branching);
  EXPECT_EQ(shipped.vocabulary.depth, d.vocabulary.depth);
  EXPECT_EQ(shipped.vocabulary.max_iterations, d.vocabulary.max_iterations);
  EXPECT_EQ(shipped.vocabulary.max_training_descriptors, d.vocabulary.max_training_descriptors);
  EXPECT_EQ(shipped.vocabulary.seed, d.vocabulary.seed);
  EXPECT_EQ(shipped.online_training_keyframes, d.online_training_keyframes);
  EXPECT_EQ(shipped.recent_keyframes_excluded, d.recent_keyframes_excluded);
  EXPECT_EQ(shipped.recent_seconds_excluded, d.recent_seconds_excluded);
  EXPECT_EQ(shipped.min_reference_score, d.min_reference_score);
  EXPECT_EQ(shipped.min_normalized_score, d.min_normalized_score);
  EXPECT_EQ(shipped.island_gap, d.island_gap);
  EXPECT_EQ(shipped.max_islands_checked, d.max_islands_checked);
  EXPECT_EQ(shipped.min_consistent_queries, d.min_consistent_queries);
  EXPECT_EQ(shipped.consistency_gap, d.consistency_gap);
  EXPECT_EQ(shipped.suppress_loop_continuation, d.suppress_loop_continuation);
  EXPECT_EQ(shipped.continuation_gap, d.continuation_gap);
  EXPECT_EQ(shipped.geometry.max_hamming, d.geometry.max_hamming);
  EXPECT_EQ(shipped.geometry.ratio, d.geometry.ratio);
  EXPECT_EQ(shipped.geometry.group_levels_up, d.geometry.group_levels_up);
  EXPECT_EQ(shipped.geometry.ransac_threshold_px, d.geometry.ransac_threshold_px);
  EXPECT_EQ(shipped.geometry.ransac_confidence, d.geometry.ransac_confidence);
  EXPECT_EQ(shipped.geometry.ransac_max_iterations, d.geometry.ransac_max_iterations);
  EXPECT_EQ(shipped.geometry.min_inliers, d.geometry.min_inliers);
  EXPECT_EQ(shipped.geometry.min_inlier_ratio, d.geometry.min_inlier_ratio);
  EXPECT_EQ(shipped.geometry.coverage_cols, d.geometry.coverage_cols);
  EXPECT_EQ(shipped.geometry.coverage_rows, d.geometry.coverage_rows);
  EXPECT_EQ(shipped.geometry.min_features_per_cell, d.geometry.min_features_per_cell);
  EXPECT_EQ(shipped.geometry.min_inliers_per_cell, d.geometry.min_inliers_per_cell);
  EXPECT_EQ(shipped.geometry.min_coverage, d.geometry.min_coverage);
  EXPECT_EQ(shipped.geometry.max_scale_change, d.geometry.max_scale_change);
}

TEST(PlaceRecognitionParamsIo, KeysOverrideAtTheTopOrUnderASection) {
  const auto top = parsePlaceRecognitionParams(
      "min_consistent_queries: 4\ngeometry: {min_coverage: 0.6}\nappearance: {max_features: 500}");
  EXPECT_EQ(top.min_consistent_queries, 4);
  EXPECT_DOUBLE_EQ(top.geometry.min_coverage, 0.6);
  EXPECT_EQ(top.appearance.max_features, 500);
  EXPECT_EQ(top.recent_keyframes_excluded,
            loop::PlaceRecognitionParams{}.recent_keyframes_excluded);
  const auto nested = parsePlaceRecognitionParams(
      "place_recognition:\n  vocabulary: {depth: 3}\n  suppress_loop_continuation: false\n");
  EXPECT_EQ(nested.vocabulary.depth, 3);
  EXPECT_FALSE(nested.suppress_loop_continuation);
  EXPECT_NO_THROW(parsePlaceRecognitionParams(""));
}

TEST(PlaceRecognitionParamsIo, RefusesTyposWrongKindsAndInvalidValues) {
  EXPECT_NE(errorOf("min_consistant_queries: 3").find("'min_consistant_queries'"),
            std::string::npos);
  EXPECT_NE(errorOf("geometry: {min_coverge: 0.5}").find("'geometry.min_coverge'"),
            std::string::npos);
  EXPECT_NE(errorOf("island_gap: [1, 2]").find("'island_gap'"), std::string::npos);
  EXPECT_NE(errorOf("geometry: 3").find("'geometry.'"), std::string::npos);
  EXPECT_NE(errorOf("geometry: {min_coverage: 2.0}").find("min_coverage"), std::string::npos);
  EXPECT_NE(errorOf("{ not yaml").find("not valid YAML"), std::string::npos);
  EXPECT_THROW(loadPlaceRecognitionParams("/no/such/file.yaml"), std::runtime_error);
}

TEST(PlaceRecognitionParamsIo, RelativeVocabularyFileIsNextToTheYaml) {
  const std::string dir = SDS_TEST_OUTPUT_DIR;
  std::ofstream(dir + "/place_recognition_test.yaml") << "vocabulary_file: words.bin\n";
  EXPECT_EQ(loadPlaceRecognitionParams(dir + "/place_recognition_test.yaml").vocabulary_file,
            dir + "/words.bin");
}

}  // namespace
}  // namespace scale_drift_slam::io
