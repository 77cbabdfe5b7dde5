#include "scale_drift_slam/features/feature_detection.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/features2d.hpp>

namespace scale_drift_slam::features {

void FeatureDetectionParams::validate() const {
  if (fast_threshold < 1 || fast_threshold > 255) {
    throw std::invalid_argument("features.fast_threshold must be in [1, 255]");
  }
  if (min_fast_threshold < 1 || min_fast_threshold > fast_threshold) {
    throw std::invalid_argument("features.min_fast_threshold must be in [1, fast_threshold]");
  }
  if (border < 3) throw std::invalid_argument("features.border must be >= 3");
  if (!(min_distance >= 0.0)) throw std::invalid_argument("features.min_distance must be >= 0");
}

std::vector<cv::KeyPoint> detectFast(const cv::Mat& grey, int threshold, int border) {
  std::vector<cv::KeyPoint> corners;
  if (grey.empty() || grey.cols <= 2 * border || grey.rows <= 2 * border) return corners;
  const cv::Rect inner(border, border, grey.cols - 2 * border, grey.rows - 2 * border);
  cv::FAST(grey(inner), corners, threshold, true);
  for (cv::KeyPoint& corner : corners) {
    corner.pt.x += static_cast<float>(border);
    corner.pt.y += static_cast<float>(border);
  }
  return corners;
}

std::vector<cv::KeyPoint> FastCornerCache::detect(int threshold, int border) {
  const std::lock_guard<std::mutex> lock(mutex_);
  Detection& detection = by_border_[border];
  if (detection.threshold < 0 || threshold < detection.threshold) {
    detection.threshold = threshold;
    detection.corners = detectFast(grey_, threshold, border);
  }
  std::vector<cv::KeyPoint> corners;
  for (const cv::KeyPoint& corner : detection.corners) {
    if (corner.response >= static_cast<float>(threshold)) corners.push_back(corner);
  }
  return corners;
}

namespace {

struct QuadCell {
  float x0, y0, x1, y1;
  std::vector<int> members;
};

void splitCell(const QuadCell& parent, const std::vector<cv::KeyPoint>& corners,
               std::vector<QuadCell>* out) {
  const float xm = 0.5f * (parent.x0 + parent.x1);
  const float ym = 0.5f * (parent.y0 + parent.y1);
  QuadCell children[4] = {{parent.x0, parent.y0, xm, ym, {}},
                          {xm, parent.y0, parent.x1, ym, {}},
                          {parent.x0, ym, xm, parent.y1, {}},
                          {xm, ym, parent.x1, parent.y1, {}}};
  for (int member : parent.members) {
    const cv::Point2f& p = corners[member].pt;
    children[(p.x >= xm ? 1 : 0) + (p.y >= ym ? 2 : 0)].members.push_back(member);
  }
  for (QuadCell& child : children) {
    if (!child.members.empty()) out->push_back(std::move(child));
  }
}

}  // namespace

std::vector<cv::KeyPoint> distributeQuadtree(const std::vector<cv::KeyPoint>& corners,
                                             int max_features, int width, int height) {
  if (max_features <= 0 || corners.empty()) return {};
  if (static_cast<int>(corners.size()) <= max_features) return corners;
  // Breadth-first rounds: every cell with more than one corner is split into quadrants, so the
  // cells stay of similar size over the image whatever the corner density. In the round that
  // would pass the budget, the most crowded cells are split first, until the budget is reached.
  std::vector<QuadCell> cells(1);
  cells[0] = {0.f, 0.f, static_cast<float>(width), static_cast<float>(height), {}};
  for (int i = 0; i < static_cast<int>(corners.size()); ++i)
    cells[0].members.push_back(i);
  while (static_cast<int>(cells.size()) < max_features) {
    std::vector<QuadCell> done, splittable;
    for (QuadCell& cell : cells) {
      const bool can_split = cell.members.size() > 1 && cell.x1 - cell.x0 >= 1.f;
      (can_split ? splittable : done).push_back(std::move(cell));
    }
    if (splittable.empty()) {
      cells = std::move(done);
      break;
    }
    std::sort(splittable.begin(), splittable.end(), [](const QuadCell& a, const QuadCell& b) {
      return a.members.size() > b.members.size();
    });
    int count = static_cast<int>(done.size() + splittable.size());
    std::size_t next = 0;
    for (; next < splittable.size() && count < max_features; ++next) {
      const std::size_t before = done.size();
      splitCell(splittable[next], corners, &done);
      count += static_cast<int>(done.size() - before) - 1;
    }
    for (; next < splittable.size(); ++next)
      done.push_back(std::move(splittable[next]));
    cells = std::move(done);
  }
  std::vector<cv::KeyPoint> selected;
  for (const QuadCell& cell : cells) {
    const auto best = std::max_element(cell.members.begin(), cell.members.end(), [&](int a, int b) {
      return corners[a].response < corners[b].response;
    });
    selected.push_back(corners[*best]);
  }
  // The last split may overshoot by up to three cells: keep the strongest.
  if (static_cast<int>(selected.size()) > max_features) {
    std::nth_element(
        selected.begin(), selected.begin() + max_features, selected.end(),
        [](const cv::KeyPoint& a, const cv::KeyPoint& b) { return a.response > b.response; });
    selected.resize(max_features);
  }
  return selected;
}

namespace {

std::vector<cv::KeyPoint> spreadCorners(FastCornerCache* fast, const cv::Size& size,
                                        int max_features, const FeatureDetectionParams& params,
                                        const std::vector<Eigen::Vector2d>& occupied) {
  if (size.empty() || max_features <= 0) return {};
  const CornerGrid occupied_grid(
      [&] {
        std::vector<cv::KeyPoint> points;
        points.reserve(occupied.size());
        for (const Eigen::Vector2d& p : occupied) {
          points.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()), 1.f);
        }
        return points;
      }(),
      size.width, size.height, 32);
  const double d = params.min_distance;
  std::vector<int> near;
  auto keepFree = [&](std::vector<cv::KeyPoint> corners) {
    if (occupied.empty() || d <= 0.0) return corners;
    std::vector<cv::KeyPoint> free;
    for (const cv::KeyPoint& corner : corners) {
      const Eigen::Vector2d c(corner.pt.x, corner.pt.y);
      occupied_grid.query(c, d, d, &near);
      bool taken = false;
      for (int i : near) {
        const cv::Point2f& o = occupied_grid.corners()[i].pt;
        if ((Eigen::Vector2d(o.x, o.y) - c).squaredNorm() < d * d) taken = true;
      }
      if (!taken) free.push_back(corner);
    }
    return free;
  };
  std::vector<cv::KeyPoint> corners = keepFree(fast->detect(params.fast_threshold, params.border));
  if (static_cast<int>(corners.size()) < max_features &&
      params.min_fast_threshold < params.fast_threshold) {
    corners = keepFree(fast->detect(params.min_fast_threshold, params.border));
  }
  return distributeQuadtree(corners, max_features, size.width, size.height);
}

}  // namespace

std::vector<cv::KeyPoint> detectSpreadCorners(const cv::Mat& grey, int max_features,
                                              const FeatureDetectionParams& params,
                                              const std::vector<Eigen::Vector2d>& occupied) {
  if (grey.empty()) return {};
  FastCornerCache corners(grey);
  return spreadCorners(&corners, grey.size(), max_features, params, occupied);
}

std::vector<cv::KeyPoint> detectSpreadCorners(const ImagePyramid& image, int max_features,
                                              const FeatureDetectionParams& params,
                                              const std::vector<Eigen::Vector2d>& occupied) {
  if (image.levels.empty()) return {};
  return spreadCorners(image.corners().get(), image.base().size(), max_features, params, occupied);
}

CornerGrid::CornerGrid(std::vector<cv::KeyPoint> corners, int width, int height, int cell_size,
                       int level)
    : corners_(std::move(corners)), level_(level), cell_size_(std::max(cell_size, 1)) {
  cols_ = std::max(1, (width + cell_size_ - 1) / cell_size_);
  rows_ = std::max(1, (height + cell_size_ - 1) / cell_size_);
  cells_.resize(static_cast<std::size_t>(cols_) * rows_);
  for (int i = 0; i < static_cast<int>(corners_.size()); ++i) {
    const int cx = std::clamp(static_cast<int>(corners_[i].pt.x) / cell_size_, 0, cols_ - 1);
    const int cy = std::clamp(static_cast<int>(corners_[i].pt.y) / cell_size_, 0, rows_ - 1);
    cells_[static_cast<std::size_t>(cy) * cols_ + cx].push_back(i);
  }
}

void CornerGrid::query(const Eigen::Vector2d& center, double rx, double ry,
                       std::vector<int>* indices) const {
  indices->clear();
  if (!center.allFinite()) return;
  const int x0 =
      std::clamp(static_cast<int>(std::floor((center.x() - rx) / cell_size_)), 0, cols_ - 1);
  const int x1 =
      std::clamp(static_cast<int>(std::floor((center.x() + rx) / cell_size_)), 0, cols_ - 1);
  const int y0 =
      std::clamp(static_cast<int>(std::floor((center.y() - ry) / cell_size_)), 0, rows_ - 1);
  const int y1 =
      std::clamp(static_cast<int>(std::floor((center.y() + ry) / cell_size_)), 0, rows_ - 1);
  for (int y = y0; y <= y1; ++y) {
    for (int x = x0; x <= x1; ++x) {
      for (int i : cells_[static_cast<std::size_t>(y) * cols_ + x]) {
        const cv::Point2f& p = corners_[i].pt;
        if (std::abs(p.x - center.x()) <= rx && std::abs(p.y - center.y()) <= ry) {
          indices->push_back(i);
        }
      }
    }
  }
}

}  // namespace scale_drift_slam::features
