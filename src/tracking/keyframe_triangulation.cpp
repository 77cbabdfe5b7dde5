#include "scale_drift_slam/tracking/keyframe_triangulation.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <opencv2/core/hal/hal.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "scale_drift_slam/features/active_search.h"
#include "scale_drift_slam/tracking/inverse_depth_filter.h"

namespace scale_drift_slam::tracking {
namespace {

constexpr double kDegToRad = M_PI / 180.0;
/// ORB's patch: corners closer to the border than its radius get no descriptor.
constexpr int kOrbPatchSize = 31;
/// A match whose alignment moves the other keyframe's pixel farther than this is dropped.
constexpr double kMaxRefinementPx = 2.0;
/// The window of that alignment (px).
constexpr int kRefinementWindow = 11;
/// The side of the patches compared for texture fixed to the sensor (as active search's).
constexpr int kFixedPatternPatch = 9;
/// A patch that correlates above this with the same pixel of the other keyframe, and better than
/// with its match there, is the sensor's texture, not the point's.
constexpr double kFixedPatternNcc = 0.8;

/// NCC of the kFixedPatternPatch-sided patches about `pa` in `a` and `pb` in `b` (bilinear).
double patchCorrelation(const cv::Mat& a, const Eigen::Vector2d& pa, const cv::Mat& b,
                        const Eigen::Vector2d& pb) {
  const cv::Size side(kFixedPatternPatch, kFixedPatternPatch);
  cv::Mat patch_a, patch_b;
  cv::getRectSubPix(a, side, cv::Point2f(static_cast<float>(pa.x()), static_cast<float>(pa.y())),
                    patch_a, CV_32F);
  cv::getRectSubPix(b, side, cv::Point2f(static_cast<float>(pb.x()), static_cast<float>(pb.y())),
                    patch_b, CV_32F);
  return features::normalizedCrossCorrelation(patch_a.ptr<float>(), patch_b.ptr<float>(),
                                              side.area());
}

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

}  // namespace

void KeyframeTriangulationParams::validate() const {
  if (max_features < 0) throw std::invalid_argument("triangulation.max_features must be >= 0");
  if (neighbours < 1) throw std::invalid_argument("triangulation.neighbours must be >= 1");
  if (max_descriptor_distance < 0 || max_descriptor_distance > 256) {
    throw std::invalid_argument("triangulation.max_descriptor_distance must be in [0, 256]");
  }
  if (!(max_ratio > 0.0 && max_ratio <= 1.0)) {
    throw std::invalid_argument("triangulation.max_ratio must be in (0, 1]");
  }
  if (!(max_epipolar_px > 0.0) || !std::isfinite(max_epipolar_px)) {
    throw std::invalid_argument("triangulation.max_epipolar_px must be > 0");
  }
  if (!(min_parallax_deg >= 0.0 && min_parallax_deg < 90.0)) {
    throw std::invalid_argument("triangulation.min_parallax_deg must be in [0, 90)");
  }
  if (!(max_reprojection_px > 0.0) || !std::isfinite(max_reprojection_px)) {
    throw std::invalid_argument("triangulation.max_reprojection_px must be > 0");
  }
}

double epipolarDistancePx(const geometry::SE3& T_b_a, const Eigen::Vector2d& xy_a,
                          const Eigen::Vector2d& xy_b, double focal) {
  const Eigen::Vector3d line =
      skew(T_b_a.translation()) * (T_b_a.rotationMatrix() * xy_a.homogeneous());
  const double norm = line.head<2>().norm();
  if (!(norm > 0.0)) return std::numeric_limits<double>::infinity();
  return focal * std::abs(line.dot(xy_b.homogeneous())) / norm;
}

std::optional<Eigen::Vector3d> triangulateMidpoint(const geometry::SE3& T_a_world,
                                                   const Eigen::Vector2d& xy_a,
                                                   const geometry::SE3& T_b_world,
                                                   const Eigen::Vector2d& xy_b) {
  const Eigen::Vector3d ca = T_a_world.inverseTranslation(), cb = T_b_world.inverseTranslation();
  const Eigen::Vector3d da = T_a_world.rotation().conjugate() * xy_a.homogeneous();
  const Eigen::Vector3d db = T_b_world.rotation().conjugate() * xy_b.homogeneous();
  // min |ca + s da - cb - t db|^2 over s, t.
  Eigen::Matrix2d A;
  A << da.dot(da), -da.dot(db), da.dot(db), -db.dot(db);
  const Eigen::Vector2d rhs((cb - ca).dot(da), (cb - ca).dot(db));
  const double det = A.determinant();
  if (!(std::abs(det) > 1e-12 * da.squaredNorm() * db.squaredNorm())) return std::nullopt;
  const Eigen::Vector2d st = A.inverse() * rhs;
  return 0.5 * (ca + st.x() * da + cb + st.y() * db);
}

cv::Mat describeCorners(const cv::Mat& grey, std::vector<cv::KeyPoint>* corners) {
  // One level, upright (angle 0): FAST corners of the base image, compared with views a few
  // frames or keyframes away, with little roll between them.
  static thread_local const cv::Ptr<cv::ORB> orb =
      cv::ORB::create(500, 1.2f, 1, kOrbPatchSize, 0, 2, cv::ORB::FAST_SCORE, kOrbPatchSize);
  for (cv::KeyPoint& corner : *corners) {
    corner.angle = 0.0f;
    corner.octave = 0;
    corner.size = static_cast<float>(kOrbPatchSize);
  }
  cv::Mat descriptors;
  if (corners->empty()) return descriptors;
  orb->compute(grey, *corners, descriptors);
  return descriptors;
}

std::vector<int> matchDescriptors(const cv::Mat& query, const cv::Mat& train, int max_distance,
                                  double max_ratio) {
  std::vector<int> match(query.rows, -1);
  std::vector<int> closest_query(train.rows, -1);
  std::vector<int> closest_distance(train.rows, std::numeric_limits<int>::max());
  for (int i = 0; i < query.rows; ++i) {
    int best = std::numeric_limits<int>::max(), second = best, best_j = -1;
    for (int j = 0; j < train.rows; ++j) {
      const int d = cv::hal::normHamming(query.ptr<uchar>(i), train.ptr<uchar>(j), query.cols);
      if (d < best) {
        second = best, best = d, best_j = j;
      } else if (d < second) {
        second = d;
      }
    }
    if (best_j < 0 || best > max_distance || best > max_ratio * second) continue;
    match[i] = best_j;
    if (best < closest_distance[best_j]) {
      closest_distance[best_j] = best;
      closest_query[best_j] = i;
    }
  }
  for (int i = 0; i < query.rows; ++i) {
    if (match[i] >= 0 && closest_query[match[i]] != i) match[i] = -1;
  }
  return match;
}

KeyframeTriangulation::KeyframeTriangulation(const KeyframeTriangulationParams& params,
                                             const features::FeatureDetectionParams& detection,
                                             double focal_length_px)
    : params_(params), detection_(detection), focal_(focal_length_px) {
  params_.validate();
}

KeyframeTriangulation::Described KeyframeTriangulation::describe(
    map::KeyframeId id, const features::ImagePyramid& image,
    const std::vector<Eigen::Vector2d>& occupied, const geometry::CameraModel& camera) const {
  Described described;
  described.id = id;
  described.image = image.base();  // shared, not copied
  described.image_for_flow = image.baseLevelForLucasKanade(kRefinementWindow);
  std::vector<cv::KeyPoint> corners =
      features::detectSpreadCorners(image, params_.max_features, detection_, occupied);
  described.descriptors = describeCorners(image.base(), &corners);
  for (const cv::KeyPoint& corner : corners) {
    const Eigen::Vector2d px(corner.pt.x, corner.pt.y);
    described.px.push_back(px);
    described.xy.push_back(camera.undistortToNormalized(px));
  }
  described.used.assign(described.px.size(), false);
  return described;
}

std::vector<map::KeyframeId> KeyframeTriangulation::neighbourIds() const {
  std::vector<map::KeyframeId> ids;
  for (const Described& described : recent_)
    ids.push_back(described.id);
  return ids;
}

std::vector<TriangulatedPoint> KeyframeTriangulation::addKeyframe(
    map::KeyframeId id, const geometry::SE3& T_kf_world, const features::ImagePyramid& image,
    const std::vector<Eigen::Vector2d>& occupied, const geometry::CameraModel& camera,
    const PoseLookup& pose_of) {
  std::vector<TriangulatedPoint> points;
  if (params_.max_features == 0) return points;
  Described current = describe(id, image, occupied, camera);
  // The newest earlier keyframe first: the smallest change of view, the most matches.
  for (auto it = recent_.rbegin(); it != recent_.rend(); ++it) {
    const std::optional<geometry::SE3> T_other_world = pose_of(it->id);
    if (T_other_world) match(current, T_kf_world, *it, *T_other_world, camera, &points);
  }
  // Keep only the unmatched corners of the new keyframe for the next ones.
  Described kept;
  kept.id = id;
  kept.image = current.image;
  kept.image_for_flow = current.image_for_flow;
  for (std::size_t i = 0; i < current.px.size(); ++i) {
    if (current.used[i]) continue;
    kept.px.push_back(current.px[i]);
    kept.xy.push_back(current.xy[i]);
    kept.descriptors.push_back(current.descriptors.row(static_cast<int>(i)));
  }
  kept.used.assign(kept.px.size(), false);
  recent_.push_back(std::move(kept));
  while (static_cast<int>(recent_.size()) > params_.neighbours)
    recent_.pop_front();
  return points;
}

std::vector<std::pair<int, int>> KeyframeTriangulation::matchAlongEpipolarLines(
    const Described& current, const Described& other, const geometry::SE3& T_other_cur) const {
  const Eigen::Matrix3d E = skew(T_other_cur.translation()) * T_other_cur.rotationMatrix();
  // For each free corner of the current keyframe: the best and second-best descriptor distance
  // among the other keyframe's free corners near its epipolar line.
  constexpr int kNone = -1;
  std::vector<int> best_of_other(other.px.size(), kNone);
  std::vector<int> best_distance_of_other(other.px.size(), std::numeric_limits<int>::max());
  std::vector<int> match_of_current(current.px.size(), kNone);
  // The other keyframe's free corners, gathered once: every corner of the current keyframe tests
  // them all against its line (400 x 400 per neighbour).
  std::vector<int> free_j;
  std::vector<double> free_x, free_y;
  for (std::size_t j = 0; j < other.px.size(); ++j) {
    if (other.used[j]) continue;
    free_j.push_back(static_cast<int>(j));
    free_x.push_back(other.xy[j].x());
    free_y.push_back(other.xy[j].y());
  }
  for (std::size_t i = 0; i < current.px.size(); ++i) {
    if (current.used[i]) continue;
    int best = std::numeric_limits<int>::max(), second = best, best_j = kNone;
    const uchar* d_i = current.descriptors.ptr<uchar>(static_cast<int>(i));
    // The epipolar line of the corner in the other keyframe, scaled to give distances in pixels.
    Eigen::Vector3d line = E * current.xy[i].homogeneous();
    const double norm = line.head<2>().norm();
    if (!(norm > 0.0)) continue;
    line *= focal_ / norm;
    const double a = line.x(), b = line.y(), c = line.z();
    for (std::size_t k = 0; k < free_j.size(); ++k) {
      if (std::abs(a * free_x[k] + b * free_y[k] + c) > params_.max_epipolar_px) continue;
      const int j = free_j[k];
      const int d =
          cv::hal::normHamming(d_i, other.descriptors.ptr<uchar>(j), other.descriptors.cols);
      if (d < best) {
        second = best, best = d, best_j = j;
      } else if (d < second) {
        second = d;
      }
    }
    if (best_j == kNone || best > params_.max_descriptor_distance ||
        (second != std::numeric_limits<int>::max() && best > params_.max_ratio * second)) {
      continue;
    }
    match_of_current[i] = best_j;
    if (best < best_distance_of_other[best_j]) {
      best_distance_of_other[best_j] = best;
      best_of_other[best_j] = static_cast<int>(i);
    }
  }
  std::vector<std::pair<int, int>> pairs;
  for (std::size_t i = 0; i < current.px.size(); ++i) {
    const int j = match_of_current[i];
    if (j != kNone && best_of_other[j] == static_cast<int>(i))  // mutual
      pairs.emplace_back(static_cast<int>(i), j);
  }
  return pairs;
}

std::vector<std::optional<Eigen::Vector2d>> KeyframeTriangulation::refine(
    const Described& current, const Described& other,
    const std::vector<std::pair<int, int>>& pairs) const {
  // FAST corners sit on whole pixels and two corners detected independently need not be the same
  // image point: the other keyframe's pixel is aligned to the current one's patch (Lucas-Kanade
  // from the match, one level), so that the two rays meet where the texture does.
  std::vector<std::optional<Eigen::Vector2d>> refined(pairs.size());
  if (pairs.empty() || current.image.empty() || other.image.empty()) return refined;
  std::vector<cv::Point2f> from, to;
  for (const auto& [i, j] : pairs) {
    from.emplace_back(static_cast<float>(current.px[i].x()), static_cast<float>(current.px[i].y()));
    to.emplace_back(static_cast<float>(other.px[j].x()), static_cast<float>(other.px[j].y()));
  }
  std::vector<unsigned char> ok;
  std::vector<float> error;
  const auto flow_input = [](const Described& d) {
    return d.image_for_flow.empty() ? cv::_InputArray(d.image) : cv::_InputArray(d.image_for_flow);
  };
  cv::calcOpticalFlowPyrLK(
      flow_input(current), flow_input(other), from, to, ok, error,
      cv::Size(kRefinementWindow, kRefinementWindow), 0,
      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 0.01),
      cv::OPTFLOW_USE_INITIAL_FLOW);
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const Eigen::Vector2d px(to[k].x, to[k].y);
    // Moved far (or lost): the texture changed too much between the views for the alignment;
    // the corner as found is the better estimate.
    const bool aligned = ok[k] && (px - other.px[pairs[k].second]).norm() <= kMaxRefinementPx;
    refined[k] = aligned ? px : other.px[pairs[k].second];
  }
  return refined;
}

void KeyframeTriangulation::match(Described& current, const geometry::SE3& T_cur_world,
                                  Described& other, const geometry::SE3& T_other_world,
                                  const geometry::CameraModel& camera,
                                  std::vector<TriangulatedPoint>* points) const {
  const geometry::SE3 T_other_cur = T_other_world * T_cur_world.inverse();
  if (!(T_other_cur.translation().norm() > 0.0)) return;  // no baseline
  const double cos_min_parallax = std::cos(params_.min_parallax_deg * kDegToRad);
  const std::vector<std::pair<int, int>> pairs =
      matchAlongEpipolarLines(current, other, T_other_cur);
  const std::vector<std::optional<Eigen::Vector2d>> refined = refine(current, other, pairs);
  const Eigen::Vector3d c_cur = T_cur_world.inverseTranslation();
  const Eigen::Vector3d c_other = T_other_world.inverseTranslation();
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    if (!refined[k]) continue;
    const auto [i, j] = pairs[k];
    // `camera` measures the current frame; the other keyframe's own (a rolling shutter's turn
    // of that frame) went into other.xy: the difference at the matched corner moves the
    // refined pixel's ray into it (0 for a global shutter).
    const Eigen::Vector2d xy_other = camera.undistortToNormalized(*refined[k]) +
                                     (other.xy[j] - camera.undistortToNormalized(other.px[j]));
    const std::optional<Eigen::Vector3d> p =
        triangulateMidpoint(T_cur_world, current.xy[i], T_other_world, xy_other);
    if (!p) continue;
    const Eigen::Vector3d in_cur = T_cur_world * *p, in_other = T_other_world * *p;
    if (!(in_cur.z() > 0.0 && in_other.z() > 0.0)) continue;
    const double error_cur = focal_ * (in_cur.head<2>() / in_cur.z() - current.xy[i]).norm();
    const double error_other = focal_ * (in_other.head<2>() / in_other.z() - xy_other).norm();
    if (error_cur > params_.max_reprojection_px || error_other > params_.max_reprojection_px)
      continue;
    const Eigen::Vector3d ray_cur = (*p - c_cur).normalized(),
                          ray_other = (*p - c_other).normalized();
    if (ray_cur.dot(ray_other) > cos_min_parallax) continue;
    if ((current.px[i] - *refined[k]).norm() < kSensorFixedPx) continue;  // fixed to the sensor
    // A point of the world whose patch is mostly texture fixed to the sensor (a saturated
    // sensor's pattern brought out by the contrast stretch, where the scene is nearly flat): the
    // corner moved, but its patch is found unchanged where it was.
    const double at_same_pixel =
        patchCorrelation(current.image, current.px[i], other.image, current.px[i]);
    if (at_same_pixel > kFixedPatternNcc &&
        at_same_pixel > patchCorrelation(current.image, current.px[i], other.image, *refined[k])) {
      continue;
    }
    current.used[i] = true;
    other.used[j] = true;
    points->push_back({*p, current.px[i], current.xy[i], other.id, xy_other});
  }
}

}  // namespace scale_drift_slam::tracking
