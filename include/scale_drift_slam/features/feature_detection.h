#pragma once
// FAST corners (OpenCV) spread evenly over the image by a quadtree (doc/algorithm.md, "feature
// initialisation": candidates "spread evenly over the image with a quadtree"), and a bucket grid
// over the corners of a frame so that active search can ask for the corners inside a region.

#include <map>
#include <mutex>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "scale_drift_slam/features/image_preparation.h"

namespace scale_drift_slam::features {

struct FeatureDetectionParams {
  int fast_threshold = 20;     ///< FAST intensity threshold for new features.
  int min_fast_threshold = 7;  ///< Retried with this when the first pass finds too few.
  int border = 12;             ///< Corners closer than this to the image border are dropped.
  double min_distance = 12.0;  ///< New corners keep this distance (px) from existing features.
  void validate() const;
};

/// FAST corners (non-maximum suppressed) at least `border` pixels inside the image.
std::vector<cv::KeyPoint> detectFast(const cv::Mat& grey, int threshold, int border);

/// The FAST corners of one image, detected once per border for every threshold asked for after
/// it: a corner's response is its FAST score, the highest threshold it passes, and the
/// non-maximum suppression keeps a corner only if no neighbour scores higher, so the corners of
/// a higher threshold are exactly those of a lower one whose response reaches it. (A border is
/// not filtered from a narrower one: the suppression next to it differs.) A frame asks for
/// corners up to three times (active search, new features and the keyframe triangulation);
/// each detection costs ~2 ms at 1241x376 on this machine. The answer is detectFast's, whoever
/// asked first. Thread-safe.
class FastCornerCache {
 public:
  explicit FastCornerCache(cv::Mat grey) : grey_(std::move(grey)) {}
  /// detectFast(grey, threshold, border), filtered from the detection kept for the border,
  /// which is made again at the lower threshold when this asks for one below it.
  std::vector<cv::KeyPoint> detect(int threshold, int border);

 private:
  struct Detection {
    int threshold = -1;  ///< -1: nothing detected yet.
    std::vector<cv::KeyPoint> corners;
  };
  std::mutex mutex_;
  cv::Mat grey_;
  std::map<int, Detection> by_border_;
};

/// Up to `max_features` corners spread over the image: the image is split recursively into
/// quadrants (always the cell holding the most corners first) until there are `max_features`
/// cells or no cell holds more than one corner; each cell keeps its strongest corner. Corners
/// closer than `params.min_distance` to a pixel of `occupied` are dropped first.
std::vector<cv::KeyPoint> detectSpreadCorners(const cv::Mat& grey, int max_features,
                                              const FeatureDetectionParams& params,
                                              const std::vector<Eigen::Vector2d>& occupied = {});
/// The same in the base level of a pyramid, with its FAST corners (ImagePyramid::corners).
std::vector<cv::KeyPoint> detectSpreadCorners(const ImagePyramid& image, int max_features,
                                              const FeatureDetectionParams& params,
                                              const std::vector<Eigen::Vector2d>& occupied = {});

/// The quadtree selection alone (exposed for tests): keeps at most `max_features` of `corners`,
/// one per cell, inside the rectangle [0, width) x [0, height).
std::vector<cv::KeyPoint> distributeQuadtree(const std::vector<cv::KeyPoint>& corners,
                                             int max_features, int width, int height);

/// The corners of one frame bucketed into square cells for region queries. Immutable once built.
class CornerGrid {
 public:
  /// `corners` in level-0 pixels, detected at pyramid `level` (0: full resolution; 1: half, each
  /// corner then within about a pixel of the full-resolution feature).
  CornerGrid(std::vector<cv::KeyPoint> corners, int width, int height, int cell_size = 16,
             int level = 0);
  /// Indices of the corners within the axis-aligned box |x - cx| <= rx, |y - cy| <= ry.
  void query(const Eigen::Vector2d& center, double rx, double ry, std::vector<int>* indices) const;
  const std::vector<cv::KeyPoint>& corners() const { return corners_; }
  int level() const { return level_; }

 private:
  std::vector<cv::KeyPoint> corners_;
  int level_;
  int cell_size_;
  int cols_;
  int rows_;
  std::vector<std::vector<int>> cells_;
};

}  // namespace scale_drift_slam::features
