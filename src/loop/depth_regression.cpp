#include "scale_drift_slam/loop/depth_regression.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include <Eigen/Cholesky>

namespace scale_drift_slam::loop {

void DepthRegressionParams::validate() const {
  if (k < 1) throw std::invalid_argument("depth regression: k must be >= 1");
  if (min_neighbours < 1 || min_neighbours > k) {
    throw std::invalid_argument("depth regression: min_neighbours must be in [1, k]");
  }
  if (!(max_distance_px > 0.0)) {
    throw std::invalid_argument("depth regression: max_distance_px must be > 0");
  }
  if (!(max_relative_spread >= 0.0)) {
    throw std::invalid_argument("depth regression: max_relative_spread must be >= 0");
  }
}

DepthRegressor::DepthRegressor(const std::vector<Eigen::Vector2d>& xy,
                               const std::vector<double>& depths, double focal_length_px,
                               const DepthRegressionParams& params)
    : params_(params) {
  params_.validate();
  if (xy.size() != depths.size()) {
    throw std::invalid_argument("depth regression: as many depths as points are needed");
  }
  if (!(focal_length_px > 0.0) || !std::isfinite(focal_length_px)) {
    throw std::invalid_argument("depth regression: the focal length must be > 0");
  }
  const double max_distance = params_.max_distance_px / focal_length_px;
  max_distance_sq_ = max_distance * max_distance;
  for (std::size_t i = 0; i < xy.size(); ++i) {
    if (depths[i] > 0.0 && std::isfinite(depths[i]) && xy[i].allFinite()) {
      xy_.push_back(xy[i]);
      depths_.push_back(depths[i]);
    }
  }
}

std::optional<double> DepthRegressor::depthAt(const Eigen::Vector2d& xy) const {
  // A keyframe holds a few hundred points: a linear scan is cheaper than building a tree.
  std::vector<std::pair<double, std::size_t>> near;
  for (std::size_t i = 0; i < xy_.size(); ++i) {
    const double d2 = (xy_[i] - xy).squaredNorm();
    if (d2 <= max_distance_sq_) near.emplace_back(d2, i);
  }
  if (static_cast<int>(near.size()) < params_.min_neighbours) return std::nullopt;
  const std::size_t k = std::min<std::size_t>(params_.k, near.size());
  std::partial_sort(near.begin(), near.begin() + k, near.end());
  std::vector<double> depths;
  for (std::size_t j = 0; j < k; ++j)
    depths.push_back(depths_[near[j].second]);
  std::sort(depths.begin(), depths.end());
  const double median = depths[depths.size() / 2];
  if (depths.back() - depths.front() > params_.max_relative_spread * median) return std::nullopt;

  // Inverse depth is linear in (x, y) on a plane: fit w = c0 + c1 (x - x_q) + c2 (y - y_q) to the
  // neighbours, weighted by inverse distance; c0 is the answer. Collinear neighbours: weighted
  // mean of w.
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  double w_sum = 0.0, weights = 0.0;
  for (std::size_t j = 0; j < k; ++j) {
    const std::size_t i = near[j].second;
    const double weight = 1.0 / (std::sqrt(near[j].first) + 1e-4);
    const Eigen::Vector3d row(1.0, xy_[i].x() - xy.x(), xy_[i].y() - xy.y());
    A += weight * row * row.transpose();
    b += weight * row / depths_[i];
    w_sum += weight / depths_[i];
    weights += weight;
  }
  double inverse_depth = w_sum / weights;
  if (k >= 3) {
    const Eigen::LDLT<Eigen::Matrix3d> ldlt(A);
    const Eigen::Vector3d c = ldlt.solve(b);
    // Trust the plane only when well conditioned and not extrapolated beyond the neighbours.
    if (ldlt.info() == Eigen::Success && c.allFinite() && 1.0 / c[0] >= 0.9 * depths.front() &&
        1.0 / c[0] <= 1.1 * depths.back() && std::abs(ldlt.vectorD().minCoeff()) > 1e-12) {
      inverse_depth = c[0];
    }
  }
  return 1.0 / inverse_depth;
}

std::optional<Eigen::Vector3d> DepthRegressor::pointAt(const Eigen::Vector2d& xy) const {
  const std::optional<double> depth = depthAt(xy);
  if (!depth) return std::nullopt;
  return *depth * Eigen::Vector3d(xy.x(), xy.y(), 1.0);
}

}  // namespace scale_drift_slam::loop
