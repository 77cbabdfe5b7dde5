#pragma once
// The settings of place recognition (doc/place_recognition.md): keyframe appearance (ORB), the
// binary vocabulary, the geometric check and the candidate logic. Plain data with defaults and
// validate(); the YAML layout is read by io/place_recognition_params_io.h.

#include <cstdint>
#include <string>

namespace scale_drift_slam::loop {

/// ORB keypoints and descriptors of one keyframe image, spread over a grid.
struct AppearanceParams {
  int max_features = 800;      ///< Upper bound of keypoints per keyframe.
  int grid_cols = 8;           ///< The image is cut into grid_cols x grid_rows cells and the
  int grid_rows = 6;           ///< keypoints are taken round-robin from them (spread).
  int pyramid_levels = 8;      ///< ORB scale pyramid.
  double scale_factor = 1.2;   ///< Between pyramid levels.
  int fast_threshold = 15;     ///< FAST threshold (grey levels) ...
  int min_fast_threshold = 6;  ///< ... lowered to this when the image yields too few corners.
  int border = 19;             ///< No keypoint closer to the border (ORB's patch needs 31 px).

  /// Throws std::invalid_argument naming the bad field.
  void validate() const;
};

/// A hierarchical k-majority tree over 256-bit descriptors (Galvez-Lopez & Tardos 2012, DBoW2).
struct VocabularyParams {
  int branching = 10;                     ///< k: children per node.
  int depth = 4;                          ///< L: levels below the root; up to k^L words.
  int max_iterations = 10;                ///< k-majority iterations per node.
  int max_training_descriptors = 200000;  ///< Randomly subsampled beyond this.
  std::uint32_t seed = 1;                 ///< k-means++ seeding and subsampling.

  void validate() const;
};

/// The check that a candidate shows the same place, not the same texture: descriptor matches
/// that agree with one epipolar geometry (fundamental matrix, or a homography for planar or
/// rotation-only views), cover a large part of both images and show it at about the same size.
struct GeometricCheckParams {
  int max_hamming = 64;              ///< Largest descriptor distance of a match (of 256 bits).
  double ratio = 0.7;                ///< Nearest / second-nearest distance ratio test.
  int group_levels_up = 3;           ///< Match within vocabulary nodes this far above words.
  double ransac_threshold_px = 3.0;  ///< Epipolar / transfer error of an inlier.
  double ransac_confidence = 0.999;
  int ransac_max_iterations = 2000;
  int min_inliers = 60;           ///< Absolute number of geometric inliers.
  double min_inlier_ratio = 0.3;  ///< Inliers / descriptor matches.
  int coverage_cols = 6;          ///< Grid over each image for the coverage test:
  int coverage_rows = 4;
  int min_features_per_cell = 3;  ///< a cell counts when it holds this many keypoints
  int min_inliers_per_cell = 2;   ///< and is covered when it holds this many inliers.
  double min_coverage = 0.5;      ///< Covered / counted cells, the smaller of both images.
  /// Largest zoom between the views (scaleChange): a camera far from where it stood before sees
  /// the same distant structure (the end of a corridor), but is not at the same place.
  double max_scale_change = 1.5;

  void validate() const;
};

struct PlaceRecognitionParams {
  AppearanceParams appearance;
  VocabularyParams vocabulary;  ///< For the vocabulary learned online (no file given).
  GeometricCheckParams geometry;

  /// A vocabulary file (Vocabulary::save); empty = learn one online from the first
  /// `online_training_keyframes` keyframes.
  std::string vocabulary_file;
  int online_training_keyframes = 30;

  /// Keyframes never proposed to a query: the `recent_keyframes_excluded` last added, and those
  /// less than `recent_seconds_excluded` older than the query.
  int recent_keyframes_excluded = 30;
  double recent_seconds_excluded = 0.0;

  /// DBoW2's normalisation: scores are divided by the score of the query against the previous
  /// keyframe; queries whose reference score is below `min_reference_score` are skipped.
  double min_reference_score = 0.005;
  double min_normalized_score = 0.3;
  int island_gap = 3;           ///< Candidates this close (in keyframes) form one island.
  int max_islands_checked = 3;  ///< Geometric checks per query, best islands first.

  /// A candidate is accepted when geometrically verified islands of `min_consistent_queries`
  /// queries lie within `consistency_gap` keyframes of each other, the queries consecutive but
  /// for at most `consistency_max_missed` queries between two of them that verified nothing
  /// near (0: strictly consecutive, DLoopDetector's rule).
  int min_consistent_queries = 3;
  int consistency_gap = 5;
  int consistency_max_missed = 2;

  /// Once a loop is accepted, candidates that just continue it (query and match both within
  /// `continuation_gap` keyframes of the last pair of that loop) are not accepted again.
  bool suppress_loop_continuation = true;
  int continuation_gap = 10;

  void validate() const;
};

}  // namespace scale_drift_slam::loop
