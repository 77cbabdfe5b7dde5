#include "scale_drift_slam/loop/geometric_check.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include <opencv2/calib3d.hpp>

#include "scale_drift_slam/common/statistics.h"

namespace scale_drift_slam::loop {
namespace {

/// Nearest and second-nearest candidate of query keypoint q among `pool`; appends the match
/// when it passes the distance and ratio tests.
SDS_HAMMING_LOOP
void matchOne(const KeyframeAppearance& query, int q, const KeyframeAppearance& candidate,
              const std::vector<int>& pool, const GeometricCheckParams& params,
              std::vector<DescriptorMatch>& out) {
  int best = -1;
  int best_distance = std::numeric_limits<int>::max();
  int second_distance = std::numeric_limits<int>::max();
  for (int c : pool) {
    const int d = hammingDistance(query.descriptor(static_cast<std::size_t>(q)),
                                  candidate.descriptor(static_cast<std::size_t>(c)));
    if (d < best_distance) {
      second_distance = best_distance;
      best_distance = d;
      best = c;
    } else if (d < second_distance) {
      second_distance = d;
    }
  }
  if (best < 0 || best_distance > params.max_hamming) return;
  if (second_distance != std::numeric_limits<int>::max() &&
      best_distance >= params.ratio * second_distance) {
    return;
  }
  out.push_back(DescriptorMatch{q, best, best_distance});
}

/// Keeps, for every candidate keypoint, only its closest match.
std::vector<DescriptorMatch> oneToOne(std::vector<DescriptorMatch> matches) {
  std::sort(matches.begin(), matches.end(), [](const DescriptorMatch& a, const DescriptorMatch& b) {
    return a.candidate != b.candidate ? a.candidate < b.candidate : a.distance < b.distance;
  });
  std::vector<DescriptorMatch> unique;
  for (const DescriptorMatch& m : matches) {
    if (unique.empty() || unique.back().candidate != m.candidate) unique.push_back(m);
  }
  std::sort(unique.begin(), unique.end(),
            [](const DescriptorMatch& a, const DescriptorMatch& b) { return a.query < b.query; });
  return unique;
}

std::string format(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.2f", value);
  return buffer;
}

}  // namespace

std::vector<DescriptorMatch> matchDescriptors(const KeyframeAppearance& query,
                                              const FeatureGroups& query_groups,
                                              const KeyframeAppearance& candidate,
                                              const FeatureGroups& candidate_groups,
                                              const GeometricCheckParams& params) {
  std::vector<DescriptorMatch> matches;
  std::size_t i = 0;
  std::size_t j = 0;
  while (i < query_groups.nodes.size() && j < candidate_groups.nodes.size()) {
    if (query_groups.nodes[i] < candidate_groups.nodes[j]) {
      ++i;
    } else if (candidate_groups.nodes[j] < query_groups.nodes[i]) {
      ++j;
    } else {
      for (int q : query_groups.features[i]) {
        matchOne(query, q, candidate, candidate_groups.features[j], params, matches);
      }
      ++i;
      ++j;
    }
  }
  return oneToOne(std::move(matches));
}

std::vector<DescriptorMatch> matchDescriptors(const KeyframeAppearance& query,
                                              const KeyframeAppearance& candidate,
                                              const GeometricCheckParams& params) {
  std::vector<int> all(candidate.size());
  for (std::size_t c = 0; c < all.size(); ++c)
    all[c] = static_cast<int>(c);
  std::vector<DescriptorMatch> matches;
  for (std::size_t q = 0; q < query.size(); ++q) {
    matchOne(query, static_cast<int>(q), candidate, all, params, matches);
  }
  return oneToOne(std::move(matches));
}

double scaleChange(const KeyframeAppearance& query, const KeyframeAppearance& candidate,
                   const std::vector<DescriptorMatch>& inliers) {
  // Pairs (k, k + n/2): n well-separated pairs in deterministic order. Pairs closer than 10 px
  // in either image say little about scale and are skipped.
  const std::size_t n = inliers.size();
  std::vector<double> ratios;
  for (std::size_t k = 0; k < n; ++k) {
    const DescriptorMatch& a = inliers[k];
    const DescriptorMatch& b = inliers[(k + n / 2) % n];
    const double d_query = cv::norm(query.keypoints.at(static_cast<std::size_t>(a.query)) -
                                    query.keypoints.at(static_cast<std::size_t>(b.query)));
    const double d_candidate =
        cv::norm(candidate.keypoints.at(static_cast<std::size_t>(a.candidate)) -
                 candidate.keypoints.at(static_cast<std::size_t>(b.candidate)));
    if (d_query < 10.0 || d_candidate < 10.0) continue;
    ratios.push_back(std::log(d_query / d_candidate));
  }
  if (ratios.size() < 2) return 1.0;
  return std::exp(std::abs(common::upperMedian(std::move(ratios))));
}

double gridCoverage(const KeyframeAppearance& appearance, const std::vector<int>& selected,
                    const GeometricCheckParams& params) {
  const int cols = params.coverage_cols;
  const int rows = params.coverage_rows;
  const auto cell = [&](const cv::Point2f& p) {
    const int cx = std::clamp(static_cast<int>(p.x * cols / appearance.image_width), 0, cols - 1);
    const int cy = std::clamp(static_cast<int>(p.y * rows / appearance.image_height), 0, rows - 1);
    return static_cast<std::size_t>(cy) * cols + cx;
  };
  std::vector<int> features(static_cast<std::size_t>(cols * rows), 0);
  std::vector<int> hits(features.size(), 0);
  for (const cv::Point2f& p : appearance.keypoints)
    ++features[cell(p)];
  for (int k : selected)
    ++hits[cell(appearance.keypoints.at(static_cast<std::size_t>(k)))];
  int textured = 0;
  int covered = 0;
  for (std::size_t c = 0; c < features.size(); ++c) {
    if (features[c] < params.min_features_per_cell) continue;
    ++textured;
    if (hits[c] >= params.min_inliers_per_cell) ++covered;
  }
  return textured == 0 ? 0.0 : static_cast<double>(covered) / textured;
}

namespace {

/// RANSAC iterations that find, with the wanted confidence, a model whose inlier share is at
/// least `share` from minimal samples of `sample` matches: log(1 - p) / log(1 - share^sample)
/// (Hartley & Zisserman, sec. 4.7.1). Models with a smaller share would be refused anyway.
int iterationsFor(double share, int sample, const GeometricCheckParams& params) {
  const double good_sample = std::pow(std::clamp(share, 1e-3, 1.0), sample);
  if (good_sample >= 1.0) return 1;
  const double n = std::log(1.0 - params.ransac_confidence) / std::log(1.0 - good_sample);
  return static_cast<int>(std::clamp(std::ceil(n), 1.0, double(params.ransac_max_iterations)));
}

/// Fills the result from a RANSAC inlier mask and applies the acceptance tests.
void evaluate(const KeyframeAppearance& query, const KeyframeAppearance& candidate,
              const std::vector<DescriptorMatch>& matches, const cv::Mat& mask,
              const GeometricCheckParams& params, GeometricCheckResult& result) {
  std::vector<int> inliers_query;
  std::vector<int> inliers_candidate;
  result.inlier_matches.clear();
  for (std::size_t k = 0; k < matches.size(); ++k) {
    if (mask.empty() || mask.at<std::uint8_t>(static_cast<int>(k)) == 0) continue;
    result.inlier_matches.push_back(matches[k]);
    inliers_query.push_back(matches[k].query);
    inliers_candidate.push_back(matches[k].candidate);
  }
  result.inliers = static_cast<int>(result.inlier_matches.size());
  result.inlier_ratio = static_cast<double>(result.inliers) / result.matches;
  result.coverage = std::min(gridCoverage(query, inliers_query, params),
                             gridCoverage(candidate, inliers_candidate, params));
  result.scale_change = scaleChange(query, candidate, result.inlier_matches);
  result.passed = false;
  if (result.inliers < params.min_inliers) {
    result.reason = "too few geometric inliers (" + std::to_string(result.inliers) + " < " +
                    std::to_string(params.min_inliers) + ")";
  } else if (result.inlier_ratio < params.min_inlier_ratio) {
    result.reason =
        "inlier ratio " + format(result.inlier_ratio) + " < " + format(params.min_inlier_ratio);
  } else if (result.coverage < params.min_coverage) {
    result.reason = "inliers cover " + format(result.coverage) + " of the image < " +
                    format(params.min_coverage) + " (a local patch, e.g. a poster)";
  } else if (result.scale_change > params.max_scale_change) {
    result.reason = "the views differ in scale by " + format(result.scale_change) + " > " +
                    format(params.max_scale_change) + " (the same structure from elsewhere)";
  } else {
    result.reason.clear();
    result.passed = true;
  }
}

}  // namespace

GeometricCheckResult checkGeometry(const KeyframeAppearance& query,
                                   const KeyframeAppearance& candidate,
                                   const std::vector<DescriptorMatch>& matches,
                                   const GeometricCheckParams& params) {
  GeometricCheckResult result;
  result.matches = static_cast<int>(matches.size());
  if (result.matches < params.min_inliers) {
    result.reason = "too few descriptor matches (" + std::to_string(result.matches) + " < " +
                    std::to_string(params.min_inliers) + ")";
    return result;
  }
  std::vector<cv::Point2f> points_query;
  std::vector<cv::Point2f> points_candidate;
  for (const DescriptorMatch& m : matches) {
    points_query.push_back(query.keypoints.at(static_cast<std::size_t>(m.query)));
    points_candidate.push_back(candidate.keypoints.at(static_cast<std::size_t>(m.candidate)));
  }
  // The smallest inlier share that could pass, which bounds the RANSAC iterations.
  const double share =
      std::max(params.min_inlier_ratio, static_cast<double>(params.min_inliers) / result.matches);
  // A homography first (4-point samples, cheap): planar scenes and pure rotations, where the
  // fundamental matrix is degenerate. OpenCV's USAC runs with a fixed seed: deterministic.
  cv::Mat mask;
  cv::findHomography(points_query, points_candidate, cv::USAC_DEFAULT, params.ransac_threshold_px,
                     mask, iterationsFor(share, 4, params), params.ransac_confidence);
  result.model = "homography";
  evaluate(query, candidate, matches, mask, params, result);
  if (result.passed) return result;
  // Then the general two-view geometry (7-point samples).
  GeometricCheckResult epipolar = result;
  mask.release();
  cv::findFundamentalMat(points_query, points_candidate, cv::USAC_DEFAULT,
                         params.ransac_threshold_px, params.ransac_confidence,
                         iterationsFor(share, 7, params), mask);
  epipolar.model = "fundamental";
  evaluate(query, candidate, matches, mask, params, epipolar);
  return epipolar.passed || epipolar.inliers > result.inliers ? epipolar : result;
}

}  // namespace scale_drift_slam::loop
