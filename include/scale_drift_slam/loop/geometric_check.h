#pragma once
// Is a place-recognition candidate the same place, or only the same texture? Descriptor matches
// between the two keyframes must agree with one two-view geometry (a fundamental matrix, or a
// homography for planar or rotation-only views, by RANSAC) AND the agreeing matches must cover a
// large part of both images: a poster or texture seen in two different places matches well, but
// only on its own patch of the image. Free functions, no state, any thread.

#include <string>
#include <vector>

#include "scale_drift_slam/loop/appearance.h"
#include "scale_drift_slam/loop/place_recognition_params.h"
#include "scale_drift_slam/loop/vocabulary.h"

namespace scale_drift_slam::loop {

/// Keypoint `query` of the query keyframe matches keypoint `candidate` of the candidate.
struct DescriptorMatch {
  int query = 0;
  int candidate = 0;
  int distance = 0;  ///< Hamming distance, of 256 bits.
};

struct GeometricCheckResult {
  bool passed = false;
  int matches = 0;            ///< Descriptor matches (ratio test, one-to-one).
  int inliers = 0;            ///< Matches agreeing with the best model.
  double inlier_ratio = 0.0;  ///< inliers / matches.
  double coverage = 0.0;      ///< Covered grid cells / textured cells, the smaller of both images.
  double scale_change = 1.0;  ///< Image-space zoom between the inliers of both views (>= 1).
  std::string model;          ///< "homography" or "fundamental": the model reported.
  std::vector<DescriptorMatch> inlier_matches;
  std::string reason;  ///< Why it failed; empty when passed.
};

/// Matches descriptors of keypoints in the same vocabulary group (FeatureGroups): nearest
/// neighbour within max_hamming, ratio test against the second nearest in the group, then one
/// match per candidate keypoint (the closest).
std::vector<DescriptorMatch> matchDescriptors(const KeyframeAppearance& query,
                                              const FeatureGroups& query_groups,
                                              const KeyframeAppearance& candidate,
                                              const FeatureGroups& candidate_groups,
                                              const GeometricCheckParams& params);
/// The same over all keypoints (brute force, no vocabulary).
std::vector<DescriptorMatch> matchDescriptors(const KeyframeAppearance& query,
                                              const KeyframeAppearance& candidate,
                                              const GeometricCheckParams& params);

/// RANSAC (OpenCV USAC) for a homography and, when that does not pass, a fundamental matrix;
/// each model must pass the inlier count, inlier ratio, coverage and scale-change tests of
/// GeometricCheckParams. RANSAC only runs the iterations needed to find a model that could pass
/// (its inlier share >= max(min_inlier_ratio, min_inliers / matches)), so hopeless candidates
/// cost little. Deterministic (fixed RANSAC seed).
GeometricCheckResult checkGeometry(const KeyframeAppearance& query,
                                   const KeyframeAppearance& candidate,
                                   const std::vector<DescriptorMatch>& matches,
                                   const GeometricCheckParams& params);

/// How much bigger the matched structure looks in one image than in the other (>= 1): the
/// median over pairs of inliers of the ratio of their pixel distances in the two images. Near 1
/// when both cameras stood at about the same distance from what they see; 1 with < 2 pairs.
double scaleChange(const KeyframeAppearance& query, const KeyframeAppearance& candidate,
                   const std::vector<DescriptorMatch>& inliers);

/// The fraction of an image's textured grid cells (>= min_features_per_cell keypoints) holding
/// at least min_inliers_per_cell of the `selected` keypoints; 0 when no cell is textured.
double gridCoverage(const KeyframeAppearance& appearance, const std::vector<int>& selected,
                    const GeometricCheckParams& params);

}  // namespace scale_drift_slam::loop
