#include "scale_drift_slam/features/active_search.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

#include <Eigen/LU>

#include "scale_drift_slam/features/fixed_point_ncc.h"

namespace scale_drift_slam::features {

void ActiveSearchParams::validate() const {
  if (template_radius < 2 || template_radius > PointAppearance::kPatchRadius / 2) {
    throw std::invalid_argument("search.template_radius must be in [2, 5]");
  }
  if (!(min_ncc > -1.0 && min_ncc < 1.0))
    throw std::invalid_argument("search.min_ncc must be in (-1, 1)");
  if (!(gate_chi2 > 0.0)) throw std::invalid_argument("search.gate_chi2 must be > 0");
  if (!(pixel_sigma_px > 0.0)) throw std::invalid_argument("search.pixel_sigma_px must be > 0");
  if (!(min_radius_px > 0.0 && max_radius_px >= min_radius_px)) {
    throw std::invalid_argument("search: need 0 < min_radius_px <= max_radius_px");
  }
  if (fast_threshold < 1) throw std::invalid_argument("search.fast_threshold must be >= 1");
  if (!(max_scale_change > 1.0)) throw std::invalid_argument("search.max_scale_change must be > 1");
  if (max_points < 1) throw std::invalid_argument("search.max_points must be >= 1");
  if (!(max_view_angle_deg > 0.0 && max_view_angle_deg <= 90.0)) {
    throw std::invalid_argument("search.max_view_angle_deg must be in (0, 90]");
  }
  if (!(min_coarse_corner_density >= 0.0)) {
    throw std::invalid_argument("search.min_coarse_corner_density must be >= 0");
  }
}

bool PointAppearance::cut(const ImagePyramid& image, const Eigen::Vector2d& px) {
  const int r = kPatchRadius;
  pixels_.clear();
  compressed_ = false;
  std::vector<std::uint8_t> pixels(kLevels * kPatchPixels);
  for (int level = 0; level < kLevels; ++level) {
    const cv::Mat* source = level < image.numLevels() ? &image.levels[level] : nullptr;
    const double s = level == 0 ? 1.0 : 0.5;
    const int x0 = static_cast<int>(std::lround(px.x() * s)) - r;
    const int y0 = static_cast<int>(std::lround(px.y() * s)) - r;
    if (!source || x0 < 0 || y0 < 0 || x0 + kPatchSide > source->cols ||
        y0 + kPatchSide > source->rows) {
      return false;  // empty(): no half-cut appearance
    }
    cv::Mat into(kPatchSide, kPatchSide, CV_8UC1, pixels.data() + level * kPatchPixels);
    (*source)(cv::Rect(x0, y0, kPatchSide, kPatchSide)).copyTo(into);
  }
  pixels_ = std::move(pixels);
  px_reference = px;
  return true;
}

void PointAppearance::setPatches(const cv::Mat& level0, const cv::Mat& level1) {
  pixels_.clear();
  compressed_ = false;
  if (level0.empty() && level1.empty()) return;
  const cv::Mat* levels[kLevels] = {&level0, &level1};
  std::vector<std::uint8_t> pixels(kLevels * kPatchPixels);
  for (int level = 0; level < kLevels; ++level) {
    const cv::Mat& from = *levels[level];
    if (from.type() != CV_8UC1 || from.rows != kPatchSide || from.cols != kPatchSide) {
      throw std::invalid_argument("point appearance: the level-" + std::to_string(level) +
                                  " patch is not a grey " + std::to_string(kPatchSide) + " x " +
                                  std::to_string(kPatchSide) + " image");
    }
    cv::Mat into(kPatchSide, kPatchSide, CV_8UC1, pixels.data() + level * kPatchPixels);
    from.copyTo(into);
  }
  pixels_ = std::move(pixels);
}

namespace {

/// Bytes of one compressed level: two 4-bit codes per byte.
constexpr int kPackedLevelBytes = (PointAppearance::kPatchPixels + 1) / 2;

std::uint8_t decodePixel(const std::uint8_t* packed, int i, std::uint8_t low, float step) {
  const int code = (i % 2 == 0) ? packed[i / 2] & 0x0F : packed[i / 2] >> 4;
  return cv::saturate_cast<std::uint8_t>(low + code * step);
}

}  // namespace

cv::Mat PointAppearance::patch(int level) const {
  if (empty() || level < 0 || level >= kLevels) return cv::Mat();
  if (!compressed_) {
    // A header over this object's pixels; the callers only read it.
    return cv::Mat(kPatchSide, kPatchSide, CV_8UC1,
                   const_cast<std::uint8_t*>(pixels_.data()) + level * kPatchPixels);
  }
  cv::Mat decoded(kPatchSide, kPatchSide, CV_8UC1);
  const std::uint8_t* packed = pixels_.data() + level * kPackedLevelBytes;
  for (int i = 0; i < kPatchPixels; ++i)
    decoded.data[i] = decodePixel(packed, i, low_[level], step_[level]);
  return decoded;
}

void PointAppearance::compress() {
  if (empty() || compressed_) return;
  std::vector<std::uint8_t> packed(kLevels * kPackedLevelBytes, 0);
  for (int level = 0; level < kLevels; ++level) {
    const std::uint8_t* from = pixels_.data() + level * kPatchPixels;
    const auto [lo, hi] = std::minmax_element(from, from + kPatchPixels);
    low_[level] = *lo;
    step_[level] = static_cast<float>(*hi - *lo) / 15.0f;
    std::uint8_t* into = packed.data() + level * kPackedLevelBytes;
    for (int i = 0; i < kPatchPixels; ++i) {
      const int code =
          step_[level] > 0.0f ? static_cast<int>(std::lround((from[i] - *lo) / step_[level])) : 0;
      into[i / 2] |= static_cast<std::uint8_t>((i % 2 == 0) ? code : code << 4);
    }
  }
  pixels_ = std::move(packed);  // a buffer of exactly the packed size
  compressed_ = true;
}

void PointAppearance::expand() {
  if (empty() || !compressed_) return;
  std::vector<std::uint8_t> pixels(kLevels * kPatchPixels);
  for (int level = 0; level < kLevels; ++level) {
    const std::uint8_t* packed = pixels_.data() + level * kPackedLevelBytes;
    for (int i = 0; i < kPatchPixels; ++i)
      pixels[level * kPatchPixels + i] = decodePixel(packed, i, low_[level], step_[level]);
  }
  pixels_ = std::move(pixels);
  compressed_ = false;
}

Eigen::Matrix2d referenceWarp(const geometry::CameraModel& camera, const Eigen::Vector3d& p_ref,
                              const Eigen::Vector3d& p_cur, const geometry::SE3& T_cur_ref) {
  const Eigen::Matrix<double, 2, 3> J_ref = camera.projectionJacobian(p_ref);
  const Eigen::Matrix<double, 2, 3> J_cur = camera.projectionJacobian(p_cur);
  // A pixel step in the reference at constant depth moves the point by J_ref2^-1 step (x, y).
  const Eigen::Matrix2d A_cur_ref =
      J_cur * T_cur_ref.rotationMatrix().leftCols<2>() * J_ref.leftCols<2>().inverse();
  return A_cur_ref.inverse();
}

double normalizedCrossCorrelation(const float* a, const float* b, int n) {
  double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
  for (int i = 0; i < n; ++i) {
    sa += a[i];
    sb += b[i];
    saa += a[i] * a[i];
    sbb += b[i] * b[i];
    sab += a[i] * b[i];
  }
  const double va = saa - sa * sa / n, vb = sbb - sb * sb / n;
  if (va < 1e-6 * n || vb < 1e-6 * n) return -1.0;
  return (sab - sa * sb / n) / std::sqrt(va * vb);
}

namespace {

/// Samples the reference template seen from the current view: T(x) = I_ref(c + A x).
bool warpTemplate(const PointAppearance& appearance, const Eigen::Matrix2d& A_ref_cur, int r,
                  std::vector<float>* out) {
  const int level = std::abs(A_ref_cur.determinant()) > 3.0 ? 1 : 0;
  const double s = level == 0 ? 1.0 : 0.5;
  const cv::Mat patch = appearance.patch(level);
  const int R = PointAppearance::kPatchRadius;
  const Eigen::Vector2d origin(std::lround(appearance.px_reference.x() * s) - R,
                               std::lround(appearance.px_reference.y() * s) - R);
  const Eigen::Vector2d center = appearance.px_reference * s - origin;
  const Eigen::Matrix2d A = A_ref_cur * s;
  out->resize(static_cast<std::size_t>(2 * r + 1) * static_cast<std::size_t>(2 * r + 1));
  int k = 0;
  for (int dy = -r; dy <= r; ++dy) {
    for (int dx = -r; dx <= r; ++dx) {
      const Eigen::Vector2d p = center + A * Eigen::Vector2d(dx, dy);
      const int x = static_cast<int>(std::floor(p.x())), y = static_cast<int>(std::floor(p.y()));
      if (x < 0 || y < 0 || x + 1 >= patch.cols || y + 1 >= patch.rows) return false;
      const double fx = p.x() - x, fy = p.y() - y;
      const unsigned char* row0 = patch.ptr<unsigned char>(y) + x;
      const unsigned char* row1 = patch.ptr<unsigned char>(y + 1) + x;
      (*out)[k++] = static_cast<float>((1 - fy) * ((1 - fx) * row0[0] + fx * row0[1]) +
                                       fy * ((1 - fx) * row1[0] + fx * row1[1]));
    }
  }
  return true;
}

/// The vertex of the parabola through (-1, a), (0, b), (1, c), within [-0.5, 0.5].
double parabolaPeak(double a, double b, double c) {
  const double denominator = a - 2.0 * b + c;
  if (!(denominator < -1e-9)) return 0.0;
  return std::clamp(0.5 * (a - c) / denominator, -0.5, 0.5);
}

}  // namespace

CornerGrid detectSearchCorners(const ImagePyramid& image, const ActiveSearchParams& params) {
  const int width = image.base().cols, height = image.base().rows;
  const int border = params.template_radius + 1;  // the template must fit at level 0
  if (image.numLevels() > 1) {
    // Level 1's pixel (u, v) is centred on level 0's (2u, 2v) (cv::pyrDown).
    std::vector<cv::KeyPoint> corners =
        detectFast(image.levels[1], params.fast_threshold, (border + 1) / 2);
    const double density = 1000.0 * static_cast<double>(corners.size()) / (width * height);
    if (density >= params.min_coarse_corner_density) {
      std::size_t kept = 0;
      for (cv::KeyPoint corner : corners) {
        corner.pt *= 2.0f;
        if (corner.pt.x < border || corner.pt.y < border || corner.pt.x >= width - border ||
            corner.pt.y >= height - border) {
          continue;
        }
        corners[kept++] = corner;
      }
      corners.resize(kept);
      return CornerGrid(std::move(corners), width, height, 16, 1);
    }
  }
  return CornerGrid(image.corners()->detect(params.fast_threshold, border), width, height);
}

namespace {

struct Prediction {
  std::size_t index;
  Eigen::Vector3d p_cur, p_ref;
};

/// Projects a point and checks that it is in the image and in its viewable range (view angle
/// and scale change against its reference keyframe).
bool predict(const SearchPoint& point, const geometry::SE3& T_cur_world,
             const geometry::CameraModel& camera, const ActiveSearchParams& params,
             Prediction* prediction, SearchMatch* match) {
  if (point.appearance == nullptr || point.appearance->empty()) return false;
  prediction->p_cur = T_cur_world * point.p_world;
  prediction->p_ref = point.T_ref_world * point.p_world;
  if (prediction->p_cur.z() <= 0.0 || prediction->p_ref.z() <= 0.0) return false;
  const auto predicted = camera.project(prediction->p_cur);
  if (!predicted || !camera.isInImage(*predicted, params.template_radius + 1)) return false;
  const Eigen::Vector3d ray_cur = point.p_world - T_cur_world.inverseTranslation();
  const Eigen::Vector3d ray_ref = point.p_world - point.T_ref_world.inverseTranslation();
  const double scale = ray_cur.norm() / ray_ref.norm();
  if (ray_cur.normalized().dot(ray_ref.normalized()) <
      std::cos(params.max_view_angle_deg * M_PI / 180.0)) {
    return false;
  }
  if (scale > params.max_scale_change || scale * params.max_scale_change < 1.0) return false;
  match->visible = true;
  match->predicted_px = *predicted;
  return true;
}

/// At most `max_points` of the predictions, spread over the image: a round robin over the cells
/// of an 8 x 6 grid.
std::vector<Prediction> spread(std::vector<Prediction> predictions,
                               const std::vector<SearchMatch>& matches, int width, int height,
                               int max_points) {
  if (static_cast<int>(predictions.size()) <= max_points) return predictions;
  constexpr int kCols = 8, kRows = 6;
  std::vector<std::vector<Prediction>> cells(static_cast<std::size_t>(kCols) * kRows);
  for (const Prediction& p : predictions) {
    const Eigen::Vector2d& px = matches[p.index].predicted_px;
    const int cx = std::clamp(static_cast<int>(px.x() * kCols / width), 0, kCols - 1);
    const int cy = std::clamp(static_cast<int>(px.y() * kRows / height), 0, kRows - 1);
    cells[cy * kCols + cx].push_back(p);
  }
  std::vector<Prediction> chosen;
  for (std::size_t round = 0; static_cast<int>(chosen.size()) < max_points; ++round) {
    bool any = false;
    for (auto& cell : cells) {
      if (round >= cell.size() || static_cast<int>(chosen.size()) >= max_points) continue;
      chosen.push_back(cell[round]);
      any = true;
    }
    if (!any) break;
  }
  return chosen;
}

/// The NCC scores of one point's template, each pixel scored once: seeds that climb towards
/// the same peak share their steps, and the parabola reuses them. Covers the point's gate box
/// with a pixel's margin; a generation stamp clears it for the next point at no cost.
class ScoreMemo {
 public:
  /// For a new point: its template, the image and the box [x0, x0 + w) x [y0, y0 + h).
  void start(const FixedPointTemplate& templ, const cv::Mat& image, int x0, int y0, int w, int h) {
    templ_ = &templ;
    image_ = &image;
    x0_ = x0;
    y0_ = y0;
    w_ = w;
    h_ = h;
    const std::size_t size = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
    if (scores_.size() < size) {
      scores_.resize(size);
      stamps_.assign(size, 0);
    }
    if (++generation_ == 0) {  // wrapped: every stamp is stale again
      std::fill(stamps_.begin(), stamps_.end(), 0);
      generation_ = 1;
    }
  }
  double score(int x, int y) {
    const int u = x - x0_, v = y - y0_;
    if (u < 0 || v < 0 || u >= w_ || v >= h_) return templ_->score(*image_, x, y);
    const std::size_t i = static_cast<std::size_t>(v) * w_ + u;
    if (stamps_[i] != generation_) {
      stamps_[i] = generation_;
      scores_[i] = templ_->score(*image_, x, y);
    }
    return scores_[i];
  }

 private:
  const FixedPointTemplate* templ_ = nullptr;
  const cv::Mat* image_ = nullptr;
  int x0_ = 0, y0_ = 0, w_ = 0, h_ = 0;
  std::vector<double> scores_;
  std::vector<std::uint32_t> stamps_;
  std::uint32_t generation_ = 0;
};

/// Climbing from half-resolution corners (CornerGrid::level() 1), whose full-resolution feature
/// is within a pixel or two: the corners scoring best where they land, and every one scoring at
/// least kClimbFromScore, climb up to kClimbSteps one-pixel steps to a local NCC maximum
/// (4-connected) inside the gate. The prediction itself is scored where it falls, as at full
/// resolution, and climbs only once it matches: climbing to a match walks a point with a wrong
/// depth onto its texture (a point pushed 15 % along its ray matched 9.9 px from where it
/// really is, test RefusedMatches).
constexpr int kClimbedSeeds = 3;
constexpr double kClimbFromScore = 0.5;
constexpr int kClimbSteps = 4;

struct ScoredPixel {
  double score;
  int x, y;
};

/// Moves `at` uphill over the 4-connected neighbours while the score rises, at most `steps`
/// times, never outside the gate.
template <typename InGate>
void climb(ScoreMemo* memo, const InGate& in_gate, int steps, ScoredPixel* at) {
  static constexpr int kStep[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
  for (int step = 0; step < steps; ++step) {
    ScoredPixel next = *at;
    for (const auto& d : kStep) {
      const int x = at->x + d[0], y = at->y + d[1];
      if (!in_gate(x, y)) continue;
      const double score = memo->score(x, y);
      if (score > next.score) next = {score, x, y};
    }
    if (next.x == at->x && next.y == at->y) return;
    *at = next;
  }
}

/// NCC matching of one predicted point: the best of the prediction itself and the FAST corners
/// inside its gated region (from half-resolution corners: after climbing to the NCC peak), then
/// the sub-pixel parabola.
void matchPoint(const SearchPoint& point, const Prediction& prediction,
                const geometry::SE3& T_cur_world, const Eigen::Matrix<double, 6, 6>& Sigma_Delta,
                const geometry::CameraModel& camera, const cv::Mat& image,
                const CornerGrid& corners, const ActiveSearchParams& params,
                std::vector<float>* samples, FixedPointTemplate* templ,
                std::vector<int>* candidates, std::vector<ScoredPixel>* seeds, ScoreMemo* memo,
                SearchMatch* match) {
  const int r = params.template_radius;
  match->searched = true;
  const geometry::SE3 T_cur_ref = T_cur_world * point.T_ref_world.inverse();
  if (!warpTemplate(*point.appearance,
                    referenceWarp(camera, prediction.p_ref, prediction.p_cur, T_cur_ref), r,
                    samples) ||
      !templ->set(*samples, r)) {
    return;
  }
  // Innovation covariance of the prediction: J Sigma_Delta J^T + sigma^2 I (+ the floor that
  // keeps the region at least min_radius_px).
  Eigen::Matrix<double, 2, 6> J;
  J << camera.projectionJacobian(prediction.p_cur) *
           geometry::SE3::actionJacobian(prediction.p_cur);
  const double floor = params.pixel_sigma_px * params.pixel_sigma_px +
                       params.min_radius_px * params.min_radius_px / params.gate_chi2;
  const Eigen::Matrix2d Sigma_z =
      J * Sigma_Delta * J.transpose() + Eigen::Matrix2d::Identity() * floor;
  const Eigen::Matrix2d information = Sigma_z.inverse();
  const double rx = std::min(std::sqrt(params.gate_chi2 * Sigma_z(0, 0)), params.max_radius_px);
  const double ry = std::min(std::sqrt(params.gate_chi2 * Sigma_z(1, 1)), params.max_radius_px);
  const Eigen::Vector2d& predicted = match->predicted_px;
  const auto in_gate = [&](double x, double y) {
    const Eigen::Vector2d d = Eigen::Vector2d(x, y) - predicted;
    return d.dot(information * d) <= params.gate_chi2;
  };
  const int cx = static_cast<int>(std::lround(predicted.x()));
  const int cy = static_cast<int>(std::lround(predicted.y()));
  const int half_w = static_cast<int>(std::ceil(rx)) + 2,
            half_h = static_cast<int>(std::ceil(ry)) + 2;
  const bool coarse = corners.level() > 0;
  // Without climbing every pixel is scored once anyway: no memo (an empty box).
  memo->start(*templ, image, cx - half_w, cy - half_h, coarse ? 2 * half_w + 1 : 0,
              coarse ? 2 * half_h + 1 : 0);
  ScoredPixel best{memo->score(cx, cy), cx, cy};
  corners.query(predicted, rx, ry, candidates);
  seeds->clear();
  for (int c : *candidates) {
    const cv::Point2f& pt = corners.corners()[c].pt;
    if (!in_gate(pt.x, pt.y)) continue;
    const int x = static_cast<int>(pt.x), y = static_cast<int>(pt.y);
    seeds->push_back({memo->score(x, y), x, y});
  }
  if (coarse) {
    const auto higher = [](const ScoredPixel& a, const ScoredPixel& b) {
      return a.score > b.score || (a.score == b.score && (a.y < b.y || (a.y == b.y && a.x < b.x)));
    };
    const std::size_t top = std::min<std::size_t>(kClimbedSeeds, seeds->size());
    std::partial_sort(seeds->begin(), seeds->begin() + top, seeds->end(), higher);
    for (std::size_t i = 0; i < seeds->size(); ++i) {
      if (i >= top && (*seeds)[i].score < kClimbFromScore) continue;
      climb(memo, in_gate, kClimbSteps, &(*seeds)[i]);
    }
  }
  for (const ScoredPixel& seed : *seeds) {
    if (seed.score > best.score) best = seed;
  }
  if (best.score < params.min_ncc) {
    match->ncc = best.score;
    return;
  }
  // A match at the prediction (no corner climbed higher) sits on the slope of its peak where
  // the prediction fell: refined to the peak before the parabola, which spans half a pixel.
  if (coarse) climb(memo, in_gate, kClimbSteps, &best);
  match->ncc = best.score;
  const double dx =
      parabolaPeak(memo->score(best.x - 1, best.y), best.score, memo->score(best.x + 1, best.y));
  const double dy =
      parabolaPeak(memo->score(best.x, best.y - 1), best.score, memo->score(best.x, best.y + 1));
  match->found = true;
  match->px = Eigen::Vector2d(best.x + dx, best.y + dy);
  match->xy = camera.undistortToNormalized(match->px);
}

}  // namespace

std::vector<SearchMatch> activeSearch(const std::vector<SearchPoint>& points,
                                      const geometry::SE3& T_cur_world,
                                      const Eigen::Matrix<double, 6, 6>& Sigma_Delta,
                                      const geometry::CameraModel& camera,
                                      const ImagePyramid& image, const CornerGrid& corners,
                                      const ActiveSearchParams& params) {
  std::vector<SearchMatch> matches(points.size());
  std::vector<Prediction> predictions;
  for (std::size_t i = 0; i < points.size(); ++i) {
    Prediction prediction{i, {}, {}};
    if (predict(points[i], T_cur_world, camera, params, &prediction, &matches[i])) {
      predictions.push_back(prediction);
    }
  }
  std::vector<float> samples;
  FixedPointTemplate templ;
  std::vector<int> candidates;
  std::vector<ScoredPixel> seeds;
  ScoreMemo memo;
  for (const Prediction& prediction : spread(std::move(predictions), matches, camera.width(),
                                             camera.height(), params.max_points)) {
    matchPoint(points[prediction.index], prediction, T_cur_world, Sigma_Delta, camera, image.base(),
               corners, params, &samples, &templ, &candidates, &seeds, &memo,
               &matches[prediction.index]);
  }
  return matches;
}

}  // namespace scale_drift_slam::features
