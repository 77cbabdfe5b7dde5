#include "scale_drift_slam/sim/renderer.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <stdexcept>

#include "span_shader.h"

namespace scale_drift_slam::sim {
namespace {

constexpr double kNear = 0.02;               ///< Near clipping distance (metres, along z).
constexpr float kInsideTolerance = 1e-6f;    ///< Closes cracks between surfaces sharing an edge.
constexpr double kMaxCurveDeviation = 0.25;  ///< Pixels; distorted edges are split until this.

using Polygon = std::vector<Eigen::Vector3d>;

/// Sutherland-Hodgman: keeps the part of the polygon where a.dot(v) >= 0.
Polygon clip(const Polygon& polygon, const Eigen::Vector3d& a) {
  Polygon out;
  for (size_t i = 0; i < polygon.size(); ++i) {
    const Eigen::Vector3d& p = polygon[i];
    const Eigen::Vector3d& q = polygon[(i + 1) % polygon.size()];
    const double fp = a.dot(p), fq = a.dot(q);
    if (fp >= 0) out.push_back(p);
    if ((fp >= 0) != (fq >= 0)) out.push_back(p + (q - p) * (fp / (fp - fq)));
  }
  return out;
}

/// The rows [begin, end) clamped to the image; end < 0 means the last row.
cv::Range clampRows(int begin, int end, int height) {
  if (end < 0) end = height;
  begin = std::clamp(begin, 0, height);
  return cv::Range(begin, std::clamp(end, begin, height));
}

}  // namespace

/// A surface in the camera frame. Per pixel with ray r (unit, or with r.z = 1 for linear cameras):
/// t = dn / (n.r) (range, or depth z), barycentric b_i = t (g_i.r) - g_i.o, texel = texel_origin
/// + texel_axes b, and the level of detail from the footprint's long axis in texels,
/// rho * range * alpha / |n.r_unit| = rho |dn| alpha |r|^2 / (n.r)^2 (rho: the surface's texel
/// density, alpha: the pixel's angular size), i.e. lod = lod_constant + lod_offset - 2 log2|n.r|
/// with lod_constant = log2(rho |dn|) and lod_offset = log2(alpha) + 2 log2|r| per pixel.
struct Renderer::Prepared {
  const Surface* surface = nullptr;
  int index = 0;
  Polygon polygon;  ///< Clipped, camera frame.
  double sort_key = 0;
  Eigen::Vector3f n, g1, g2;
  float dn = 0, g1o = 0, g2o = 0;
  float lod_constant = 0;
  bool triangle = false;
};

Renderer::Renderer(const geometry::CameraModel& camera)
    : camera_(geometry::makeCameraModel(camera.calibration())),
      vectorised_(detail::vectorShadingAvailable()),
      width_(camera.width()),
      height_(camera.height()) {
  const geometry::CameraCalibration& c = camera.calibration();
  linear_ = c.model == geometry::DistortionModel::kRadialTangential &&
            std::all_of(c.distortion.begin(), c.distortion.end(), [](double d) { return d == 0; });
  const size_t n = static_cast<size_t>(width_) * static_cast<size_t>(height_);
  // 8 spare values: the vector shader reads whole groups of 8 pixels.
  for (auto* v : {&ray_x_, &ray_y_, &ray_z_, &lod_offset_})
    v->assign(n + 8, 0.0f);
  x_min_ = y_min_ = std::numeric_limits<double>::infinity();
  x_max_ = y_max_ = -x_min_;
  std::vector<Eigen::Vector3d> row_rays(static_cast<size_t>(width_ + 1));
  std::vector<Eigen::Vector3d> next_rays(static_cast<size_t>(width_ + 1));
  auto fill_row = [&](int y, std::vector<Eigen::Vector3d>& out) {
    for (int x = 0; x <= width_; ++x) {
      out[static_cast<size_t>(x)] = camera_->unproject(Eigen::Vector2d(x, y)).normalized();
    }
  };
  fill_row(0, row_rays);
  for (int y = 0; y < height_; ++y) {
    fill_row(y + 1, next_rays);
    for (int x = 0; x < width_; ++x) {
      const Eigen::Vector3d& r = row_rays[static_cast<size_t>(x)];
      if (!(r.z() > 0.05)) {
        throw std::invalid_argument(
            "the renderer needs every pixel within 87 degrees of the "
            "optical axis; this camera sees wider");
      }
      const size_t i =
          static_cast<size_t>(y) * static_cast<size_t>(width_) + static_cast<size_t>(x);
      ray_x_[i] = static_cast<float>(r.x());
      ray_y_[i] = static_cast<float>(r.y());
      ray_z_[i] = static_cast<float>(r.z());
      const double alpha = std::max((row_rays[static_cast<size_t>(x) + 1] - r).norm(),
                                    (next_rays[static_cast<size_t>(x)] - r).norm());
      // The linear path uses r / r.z, whose length is 1 / r.z.
      lod_offset_[i] = static_cast<float>(std::log2(std::max(alpha, 1e-9)) -
                                          (linear_ ? 2.0 * std::log2(r.z()) : 0.0));
      x_min_ = std::min(x_min_, r.x() / r.z());
      x_max_ = std::max(x_max_, r.x() / r.z());
      y_min_ = std::min(y_min_, r.y() / r.z());
      y_max_ = std::max(y_max_, r.y() / r.z());
    }
    std::swap(row_rays, next_rays);
  }
  const double margin_x = 0.02 * (x_max_ - x_min_), margin_y = 0.02 * (y_max_ - y_min_);
  x_min_ -= margin_x;
  x_max_ += margin_x;
  y_min_ -= margin_y;
  y_max_ += margin_y;
  depth_.create(height_, width_, CV_32F);
  const geometry::CameraCalibration& k = camera.calibration();
  for (int x = 0; x < width_; ++x)
    column_x_.push_back(static_cast<float>((x - k.cx) / k.fx));
  for (int y = 0; y < height_; ++y)
    row_y_.push_back(static_cast<float>((y - k.cy) / k.fy));
  index_.create(height_, width_, CV_32S);
  span_lo_.resize(static_cast<size_t>(height_));
  span_hi_.resize(static_cast<size_t>(height_));
}

void Renderer::setVectorised(bool vectorised) {
  vectorised_ = vectorised && detail::vectorShadingAvailable();
}

cv::Mat Renderer::range() const {
  if (!linear_) return depth_.clone();
  cv::Mat range(height_, width_, CV_32F);
  for (int y = 0; y < height_; ++y) {
    for (int x = 0; x < width_; ++x) {
      const float xn = column_x_[static_cast<size_t>(x)], yn = row_y_[static_cast<size_t>(y)];
      range.at<float>(y, x) = depth_.at<float>(y, x) * std::sqrt(1.0f + xn * xn + yn * yn);
    }
  }
  return range;
}

Eigen::Vector3f Renderer::point(int x, int y) const {
  const float depth = depth_.at<float>(y, x);  // z (linear camera) or range along the unit ray
  if (linear_) {
    return depth *
           Eigen::Vector3f(column_x_[static_cast<size_t>(x)], row_y_[static_cast<size_t>(y)], 1.0f);
  }
  return depth * ray(x, y);
}

Eigen::Vector3f Renderer::ray(int x, int y) const {
  const size_t i = static_cast<size_t>(y) * static_cast<size_t>(width_) + static_cast<size_t>(x);
  return Eigen::Vector3f(ray_x_[i], ray_y_[i], ray_z_[i]);
}

bool Renderer::prepare(const Surface& s, const Scene& scene, const Eigen::Matrix3d& R,
                       const Eigen::Vector3d& t, Prepared& out) const {
  if (s.hidden) return false;
  const Eigen::Vector3d o = R * s.origin + t, e1 = R * s.edge1, e2 = R * s.edge2;
  Polygon polygon = {o, o + e1};
  if (s.shape == Surface::Shape::kParallelogram) polygon.push_back(o + e1 + e2);
  polygon.push_back(o + e2);
  // Quick rejection: every corner outside the same side of the viewing frustum.
  const Eigen::Vector3d planes[5] = {
      {0, 0, 1}, {-1, 0, x_max_}, {1, 0, -x_min_}, {0, -1, y_max_}, {0, 1, -y_min_}};
  for (const Eigen::Vector3d& plane : planes) {
    if (std::all_of(polygon.begin(), polygon.end(),
                    [&](const Eigen::Vector3d& p) { return plane.dot(p) < 0; })) {
      return false;
    }
  }
  const Eigen::Vector3d normal = e1.cross(e2).normalized();
  const double dn = normal.dot(o);
  if (std::abs(dn) < 1e-9) return false;        // the camera lies in the plane
  if (!s.double_sided && dn < 0) return false;  // seen from the back (see Surface)
  for (const Eigen::Vector3d& plane : {planes[1], planes[2], planes[3], planes[4]}) {
    if (polygon.size() < 3) return false;
    polygon = clip(polygon, plane);
  }
  // The near plane z >= kNear.
  Polygon near_clipped;
  for (size_t i = 0; i < polygon.size(); ++i) {
    const Eigen::Vector3d& p = polygon[i];
    const Eigen::Vector3d& q = polygon[(i + 1) % polygon.size()];
    const double fp = p.z() - kNear, fq = q.z() - kNear;
    if (fp >= 0) near_clipped.push_back(p);
    if ((fp >= 0) != (fq >= 0)) near_clipped.push_back(p + (q - p) * (fp / (fp - fq)));
  }
  if (near_clipped.size() < 3) return false;
  out.polygon = std::move(near_clipped);
  out.sort_key = std::numeric_limits<double>::infinity();
  for (const Eigen::Vector3d& p : out.polygon)
    out.sort_key = std::min(out.sort_key, p.norm());

  // Dual basis of (e1, e2) in the plane: G = E (E^T E)^-1, so that b = G^T (X - o).
  Eigen::Matrix<double, 3, 2> E;
  E << e1, e2;
  const Eigen::Matrix2d gram_inverse = (E.transpose() * E).inverse();
  const Eigen::Matrix<double, 3, 2> G = E * gram_inverse;
  out.n = normal.cast<float>();
  out.dn = static_cast<float>(dn);
  out.g1 = G.col(0).cast<float>();
  out.g2 = G.col(1).cast<float>();
  out.g1o = static_cast<float>(G.col(0).dot(o));
  out.g2o = static_cast<float>(G.col(1).dot(o));
  // Texel density: largest singular value of texel_axes (E^T E)^-1/2 (texels per metre).
  const Eigen::Matrix2d M = s.texel_axes * gram_inverse * s.texel_axes.transpose();
  const double half_trace = 0.5 * (M(0, 0) + M(1, 1));
  const double largest = half_trace + std::hypot(0.5 * (M(0, 0) - M(1, 1)), M(0, 1));
  const double rho = std::sqrt(std::max(largest, 1e-18));
  out.lod_constant = static_cast<float>(std::log2(rho * std::abs(dn)));
  out.triangle = s.shape == Surface::Shape::kTriangle;
  out.surface = &s;
  (void)scene;
  return true;
}

bool Renderer::projectPoint(const Eigen::Vector3d& p, Eigen::Vector2d& pixel) const {
  if (linear_) {
    const geometry::CameraCalibration& c = camera_->calibration();
    pixel = Eigen::Vector2d(c.fx * p.x() / p.z() + c.cx, c.fy * p.y() / p.z() + c.cy);
    return true;
  }
  const std::optional<Eigen::Vector2d> projected = camera_->project(p);
  if (!projected) return false;
  pixel = *projected;
  return true;
}

void Renderer::appendEdge(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                          const Eigen::Vector2d& pa, const Eigen::Vector2d& pb, int depth,
                          std::vector<Eigen::Vector2d>& out) const {
  if (!linear_ && depth < 12) {
    const Eigen::Vector3d m = 0.5 * (a + b);
    Eigen::Vector2d pm;
    if (projectPoint(m, pm)) {
      const Eigen::Vector2d chord = pb - pa;
      const double length = chord.norm();
      const double deviation =
          length > 1e-9 ? std::abs(chord.x() * (pm - pa).y() - chord.y() * (pm - pa).x()) / length
                        : (pm - pa).norm();
      if (deviation > kMaxCurveDeviation || length > 0.5 * (width_ + height_)) {
        appendEdge(a, m, pa, pm, depth + 1, out);
        appendEdge(m, b, pm, pb, depth + 1, out);
        return;
      }
    }
  }
  out.push_back(pa);
}

bool Renderer::computeSpans(const Prepared& surface, int& row_begin, int& row_end) {
  const Polygon& polygon = surface.polygon;
  std::vector<Eigen::Vector2d> projected(polygon.size());
  for (size_t i = 0; i < polygon.size(); ++i) {
    if (!projectPoint(polygon[i], projected[i])) return false;
  }
  boundary_.clear();
  for (size_t i = 0; i < polygon.size(); ++i) {
    const size_t j = (i + 1) % polygon.size();
    appendEdge(polygon[i], polygon[j], projected[i], projected[j], 0, boundary_);
  }
  double y_lo = std::numeric_limits<double>::infinity(), y_hi = -y_lo;
  for (const Eigen::Vector2d& p : boundary_) {
    y_lo = std::min(y_lo, p.y());
    y_hi = std::max(y_hi, p.y());
  }
  row_begin = std::max(0, static_cast<int>(std::floor(y_lo)) - 1);
  row_end = std::min(height_, static_cast<int>(std::ceil(y_hi)) + 2);
  if (row_begin >= row_end) return true;
  std::fill(span_lo_.begin() + row_begin, span_lo_.begin() + row_end,
            std::numeric_limits<float>::infinity());
  std::fill(span_hi_.begin() + row_begin, span_hi_.begin() + row_end,
            -std::numeric_limits<float>::infinity());
  // Each boundary segment widens the span of every row within one pixel of it (conservative; the
  // per-pixel inside test decides exactly).
  for (size_t i = 0; i < boundary_.size(); ++i) {
    const Eigen::Vector2d& p = boundary_[i];
    const Eigen::Vector2d& q = boundary_[(i + 1) % boundary_.size()];
    const double ya = std::min(p.y(), q.y()), yb = std::max(p.y(), q.y());
    const int r0 = std::max(row_begin, static_cast<int>(std::floor(ya)) - 1);
    const int r1 = std::min(row_end - 1, static_cast<int>(std::ceil(yb)) + 1);
    for (int r = r0; r <= r1; ++r) {
      const double y0 = std::max(ya, r - 1.0), y1 = std::min(yb, r + 1.0);
      if (y0 > y1) continue;
      double x0, x1;
      if (yb - ya < 1e-9) {
        x0 = p.x();
        x1 = q.x();
      } else {
        x0 = p.x() + (q.x() - p.x()) * (y0 - p.y()) / (q.y() - p.y());
        x1 = p.x() + (q.x() - p.x()) * (y1 - p.y()) / (q.y() - p.y());
      }
      const size_t row = static_cast<size_t>(r);
      span_lo_[row] = std::min(span_lo_[row], static_cast<float>(std::min(x0, x1) - 1.0));
      span_hi_[row] = std::max(span_hi_[row], static_cast<float>(std::max(x0, x1) + 1.0));
    }
  }
  return true;
}

void Renderer::rasterise(const Prepared& ps, const Scene& scene, int rows_lo, int rows_hi,
                         cv::Mat& image) {
  int row_begin = 0, row_end = height_;
  const bool bounded = computeSpans(ps, row_begin, row_end);
  row_begin = std::max(row_begin, rows_lo);
  row_end = std::min(row_end, rows_hi);
  detail::Span span;
  for (int k = 0; k < 3; ++k) {
    span.n[k] = ps.n[k];
    span.g1[k] = ps.g1[k];
    span.g2[k] = ps.g2[k];
  }
  span.dn = ps.dn;
  span.g1o = ps.g1o;
  span.g2o = ps.g2o;
  span.lod_constant = ps.lod_constant;
  span.gain = ps.surface->gain;
  span.texel_origin[0] = static_cast<float>(ps.surface->texel_origin.x());
  span.texel_origin[1] = static_cast<float>(ps.surface->texel_origin.y());
  const Eigen::Matrix2d& A = ps.surface->texel_axes;
  span.texel_axes[0] = static_cast<float>(A(0, 0));
  span.texel_axes[1] = static_cast<float>(A(0, 1));
  span.texel_axes[2] = static_cast<float>(A(1, 0));
  span.texel_axes[3] = static_cast<float>(A(1, 1));
  span.triangle = ps.triangle;
  span.surface_index = ps.index;
  span.tolerance = kInsideTolerance;
  span.texture = &scene.texture(ps.surface->texture);
  for (int y = row_begin; y < row_end; ++y) {
    int x_begin = 0, x_end = width_;
    if (bounded) {
      const float lo = span_lo_[static_cast<size_t>(y)], hi = span_hi_[static_cast<size_t>(y)];
      if (!(lo <= hi)) continue;
      x_begin = std::max(0, static_cast<int>(std::floor(lo)));
      x_end = std::min(width_, static_cast<int>(std::ceil(hi)) + 1);
    }
    const size_t row_offset = static_cast<size_t>(y) * static_cast<size_t>(width_);
    span.x_begin = x_begin;
    span.x_end = x_end;
    span.depth = depth_.ptr<float>(y);
    span.index = index_.ptr<int>(y);
    span.out = image.ptr<std::uint8_t>(y);
    span.lod_offset = &lod_offset_[row_offset];
    if (linear_) {  // r = (x/z, y/z, 1)
      span.rx = column_x_.data();
      span.ry = nullptr;
      span.rz = nullptr;
      span.ry_value = row_y_[static_cast<size_t>(y)];
    } else {
      span.rx = &ray_x_[row_offset];
      span.ry = &ray_y_[row_offset];
      span.rz = &ray_z_[row_offset];
    }
    if (vectorised_) {
      detail::shadeSpanVector(span);
    } else {
      detail::shadeSpanScalar(span);
    }
  }
}

void Renderer::render(const Scene& scene, const geometry::SE3& T_cam_world, cv::Mat& image,
                      int row_begin, int row_end) {
  image.create(height_, width_, CV_8UC1);
  const cv::Range rows = clampRows(row_begin, row_end, height_);
  depth_.rowRange(rows).setTo(cv::Scalar(std::numeric_limits<float>::infinity()));
  index_.rowRange(rows).setTo(cv::Scalar(-1));
  const Eigen::Matrix3d R = T_cam_world.rotationMatrix();
  const Eigen::Vector3d& t = T_cam_world.translation();
  std::vector<Prepared> visible;
  const std::vector<Surface>& surfaces = scene.surfaces();
  for (size_t i = 0; i < surfaces.size(); ++i) {
    Prepared prepared;
    if (!prepare(surfaces[i], scene, R, t, prepared)) continue;
    prepared.index = static_cast<int>(i);
    visible.push_back(std::move(prepared));
  }
  // Front to back: nearer surfaces fill the z-buffer first, hidden pixels are then not shaded.
  std::sort(visible.begin(), visible.end(),
            [](const Prepared& a, const Prepared& b) { return a.sort_key < b.sort_key; });
  for (const Prepared& prepared : visible)
    rasterise(prepared, scene, rows.start, rows.end, image);

  // Background: by the elevation of the ray in the world, (R^T r).z = R.col(2).r.
  const Eigen::Vector3f up = R.col(2).cast<float>();
  const Background& background = scene.background();
  for (int y = rows.start; y < rows.end; ++y) {
    const int* index = index_.ptr<int>(y);
    std::uint8_t* out = image.ptr<std::uint8_t>(y);
    for (int x = 0; x < width_; ++x) {
      if (index[x] >= 0) continue;
      const size_t i =
          static_cast<size_t>(y) * static_cast<size_t>(width_) + static_cast<size_t>(x);
      const float r[3] = {ray_x_[i], ray_y_[i], ray_z_[i]};
      const float level = background.level(up.x() * r[0] + up.y() * r[1] + up.z() * r[2]);
      out[x] = static_cast<std::uint8_t>(std::clamp(level + 0.5f, 0.0f, 255.0f));
    }
  }
}

void Renderer::renderColor(const Scene& scene, const geometry::SE3& T_cam_world, cv::Mat& image,
                           int row_begin, int row_end) {
  cv::Mat grey;
  render(scene, T_cam_world, grey, row_begin, row_end);
  const cv::Range rows = clampRows(row_begin, row_end, height_);
  image.create(height_, width_, CV_8UC3);
  const std::vector<Surface>& surfaces = scene.surfaces();
  for (int y = rows.start; y < rows.end; ++y) {
    const int* index = index_.ptr<int>(y);
    const std::uint8_t* in = grey.ptr<std::uint8_t>(y);
    cv::Vec3b* out = image.ptr<cv::Vec3b>(y);
    for (int x = 0; x < width_; ++x) {
      const Eigen::Vector3f& tint =
          index[x] >= 0 ? surfaces[static_cast<size_t>(index[x])].tint : scene.background().tint;
      for (int c = 0; c < 3; ++c)
        out[x][c] = cv::saturate_cast<std::uint8_t>(in[x] * tint[c]);
    }
  }
}

}  // namespace scale_drift_slam::sim
