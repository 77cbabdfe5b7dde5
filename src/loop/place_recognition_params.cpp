#include "scale_drift_slam/loop/place_recognition_params.h"

#include <cmath>
#include <stdexcept>

namespace scale_drift_slam::loop {
namespace {

void require(bool condition, const std::string& what) {
  if (!condition) throw std::invalid_argument("place recognition params: " + what);
}

}  // namespace

void AppearanceParams::validate() const {
  require(max_features >= 10 && max_features <= 100000,
          "appearance.max_features must be in [10, 100000]");
  require(grid_cols >= 1 && grid_rows >= 1 && grid_cols * grid_rows <= max_features,
          "appearance.grid_cols and grid_rows must be >= 1 with at most max_features cells");
  require(pyramid_levels >= 1 && pyramid_levels <= 16, "appearance.pyramid_levels in [1, 16]");
  require(std::isfinite(scale_factor) && scale_factor > 1.0 && scale_factor <= 2.0,
          "appearance.scale_factor must be in (1, 2]");
  require(fast_threshold >= 1 && fast_threshold <= 255, "appearance.fast_threshold in [1, 255]");
  require(min_fast_threshold >= 1 && min_fast_threshold <= fast_threshold,
          "appearance.min_fast_threshold must be in [1, fast_threshold]");
  require(border >= 16, "appearance.border must be >= 16 (half the ORB patch)");
}

void VocabularyParams::validate() const {
  require(branching >= 2 && branching <= 64, "vocabulary.branching must be in [2, 64]");
  require(depth >= 1 && depth <= 8, "vocabulary.depth must be in [1, 8]");
  require(std::pow(static_cast<double>(branching), depth) <= 4.0e6,
          "vocabulary.branching^depth must be at most 4e6 words");
  require(max_iterations >= 1, "vocabulary.max_iterations must be >= 1");
  require(max_training_descriptors >= branching,
          "vocabulary.max_training_descriptors must be >= branching");
}

void GeometricCheckParams::validate() const {
  require(max_hamming >= 1 && max_hamming <= 256, "geometry.max_hamming in [1, 256]");
  require(ratio > 0.0 && ratio <= 1.0, "geometry.ratio must be in (0, 1]");
  require(group_levels_up >= 0, "geometry.group_levels_up must be >= 0");
  require(std::isfinite(ransac_threshold_px) && ransac_threshold_px > 0.0,
          "geometry.ransac_threshold_px must be > 0");
  require(ransac_confidence > 0.0 && ransac_confidence < 1.0,
          "geometry.ransac_confidence must be in (0, 1)");
  require(ransac_max_iterations >= 1, "geometry.ransac_max_iterations must be >= 1");
  require(min_inliers >= 8, "geometry.min_inliers must be >= 8 (the 8-point fundamental matrix)");
  require(min_inlier_ratio >= 0.0 && min_inlier_ratio <= 1.0,
          "geometry.min_inlier_ratio must be in [0, 1]");
  require(coverage_cols >= 1 && coverage_rows >= 1, "geometry.coverage_cols/rows must be >= 1");
  require(min_features_per_cell >= 1, "geometry.min_features_per_cell must be >= 1");
  require(min_inliers_per_cell >= 1, "geometry.min_inliers_per_cell must be >= 1");
  require(min_coverage >= 0.0 && min_coverage <= 1.0, "geometry.min_coverage must be in [0, 1]");
  require(std::isfinite(max_scale_change) && max_scale_change >= 1.0,
          "geometry.max_scale_change must be >= 1");
}

void PlaceRecognitionParams::validate() const {
  appearance.validate();
  vocabulary.validate();
  geometry.validate();
  require(online_training_keyframes >= 1, "online_training_keyframes must be >= 1");
  require(recent_keyframes_excluded >= 1, "recent_keyframes_excluded must be >= 1");
  require(std::isfinite(recent_seconds_excluded) && recent_seconds_excluded >= 0.0,
          "recent_seconds_excluded must be >= 0");
  require(min_reference_score >= 0.0 && min_reference_score < 1.0,
          "min_reference_score must be in [0, 1)");
  require(std::isfinite(min_normalized_score) && min_normalized_score >= 0.0,
          "min_normalized_score must be >= 0");
  require(island_gap >= 1, "island_gap must be >= 1");
  require(max_islands_checked >= 1, "max_islands_checked must be >= 1");
  require(min_consistent_queries >= 1, "min_consistent_queries must be >= 1");
  require(consistency_gap >= 0, "consistency_gap must be >= 0");
  require(consistency_max_missed >= 0, "consistency_max_missed must be >= 0");
  require(continuation_gap >= 0, "continuation_gap must be >= 0");
}

}  // namespace scale_drift_slam::loop
