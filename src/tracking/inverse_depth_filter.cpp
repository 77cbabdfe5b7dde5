#include "scale_drift_slam/tracking/inverse_depth_filter.h"

#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/LU>

#include "small_levenberg_marquardt.h"

namespace scale_drift_slam::tracking {

void InverseDepthFilterParams::validate() const {
  auto fail = [](const std::string& what) {
    throw std::invalid_argument("inverse-depth filter: " + what);
  };
  if (!(pixel_sigma_px > 0.0)) fail("pixel_sigma_px must be > 0");
  if (!(min_parallax_deg >= 0.0 && min_parallax_deg < 90.0)) {
    fail("min_parallax_deg must be in [0, 90)");
  }
  if (!(max_residual_sigmas > 0.0)) fail("max_residual_sigmas must be > 0");
  if (max_iterations < 1) fail("max_iterations must be >= 1");
  if (!(max_relative_depth_sigma > 0.0)) fail("max_relative_depth_sigma must be > 0");
  if (min_updates < 1) fail("min_updates must be >= 1");
  if (!(max_promotion_error_px > 0.0)) fail("max_promotion_error_px must be > 0");
}

double parallaxAngle(const Eigen::Matrix3d& R_cur_org, const Eigen::Vector2d& xy_origin,
                     const Eigen::Vector2d& xy_current) {
  const Eigen::Vector3d a = R_cur_org * xy_origin.homogeneous();
  const Eigen::Vector3d b = xy_current.homogeneous();
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

namespace {

/// The measurement model h(y) = proj(R m + q t) with m = (u, v, 1) and (R, t) = T_cur_org: the
/// projection of x_org = m / q, multiplied through by q (projection is scale invariant), which
/// stays defined at q = 0 (a point at infinity). Also J = dh/dy: dp/du = R e1, dp/dv = R e2,
/// dp/dq = t with p = R m + q t. Returns false when p is not in front of the camera.
bool measurementModel(const Eigen::Matrix3d& R, const Eigen::Vector3d& t, const Eigen::Vector3d& y,
                      Eigen::Vector2d* h, Eigen::Matrix<double, 2, 3>* J) {
  const Eigen::Vector3d p = R * Eigen::Vector3d(y.x(), y.y(), 1.0) + y.z() * t;
  if (!(p.z() > 1e-9)) return false;
  const double inv_z = 1.0 / p.z();
  *h = p.head<2>() * inv_z;
  Eigen::Matrix<double, 2, 3> d_proj;
  d_proj << inv_z, 0.0, -h->x() * inv_z, 0.0, inv_z, -h->y() * inv_z;
  Eigen::Matrix3d dp_dy;
  dp_dy << R.col(0), R.col(1), t;
  *J = d_proj * dp_dy;
  return true;
}

}  // namespace

InverseDepthFilter::InverseDepthFilter(map::KeyframeId origin_id,
                                       const geometry::SE3& T_origin_world,
                                       const Eigen::Vector2d& xy_origin,
                                       double initial_inverse_depth, double focal_length_px,
                                       const InverseDepthFilterParams& params)
    : origin_id_(origin_id),
      T_origin_world_(T_origin_world),
      y_(xy_origin.x(), xy_origin.y(), initial_inverse_depth),
      focal_length_px_(focal_length_px),
      params_(params) {
  params_.validate();
  if (!xy_origin.allFinite() || !(initial_inverse_depth > 0.0) ||
      !std::isfinite(initial_inverse_depth) || !(focal_length_px > 0.0)) {
    throw std::invalid_argument(
        "inverse-depth filter: needs a finite observation, inverse depth > 0 and focal length > 0");
  }
  const double sigma = params_.pixel_sigma_px / focal_length_px_;  // normalised units
  information_ = Eigen::Vector3d(1.0 / (sigma * sigma), 1.0 / (sigma * sigma), 0.0).asDiagonal();
}

double InverseDepthFilter::parallax(const geometry::SE3& T_cam_world,
                                    const Eigen::Vector2d& xy) const {
  const Eigen::Matrix3d R_cur_org =
      T_cam_world.rotationMatrix() * T_origin_world_.rotationMatrix().transpose();
  return parallaxAngle(R_cur_org, y_.head<2>(), xy);
}

InverseDepthFilter::Update InverseDepthFilter::update(const geometry::SE3& T_cam_world,
                                                      const Eigen::Vector2d& xy) {
  constexpr double kDegree = 3.14159265358979323846 / 180.0;
  if (parallax(T_cam_world, xy) < params_.min_parallax_deg * kDegree) return Update::kLowParallax;
  if (focal_length_px_ * (xy - y_.head<2>()).norm() < kSensorFixedPx) return Update::kRejected;
  const geometry::SE3 T_cur_org = T_cam_world * T_origin_world_.inverse();
  const Eigen::Matrix3d R = T_cur_org.rotationMatrix();
  const Eigen::Vector3d t = T_cur_org.translation();
  const double sigma = params_.pixel_sigma_px / focal_length_px_;
  const double w = 1.0 / (sigma * sigma);  // Lambda_z = w I

  // chi2(y) = (y - y0)^T Lambda (y - y0) + w |z - h(y)|^2 (paper eq. 19), minimised with LM;
  // q < 0 (behind the origin) and points behind the current camera are infeasible.
  const Eigen::Vector3d y0 = y_;
  auto chi2 = [&](const Eigen::Vector3d& y, Eigen::Matrix3d* H, Eigen::Vector3d* g) {
    Eigen::Vector2d h;
    Eigen::Matrix<double, 2, 3> J;
    if (!(y.z() >= 0.0) || !measurementModel(R, t, y, &h, &J)) {
      return std::numeric_limits<double>::infinity();
    }
    const Eigen::Vector3d d = y - y0;
    if (H != nullptr) {
      *H = information_ + w * J.transpose() * J;
      *g = information_ * d - w * J.transpose() * (xy - h);
    }
    return d.dot(information_ * d) + w * (xy - h).squaredNorm();
  };
  internal::SmallLmOptions lm;
  lm.max_iterations = params_.max_iterations;
  lm.initial_damping = 1e-3;
  lm.min_diagonal = 1e-12 * w;
  Eigen::Vector3d y = y0;
  if (!std::isfinite(internal::minimiseSmallLm(&y, lm, chi2))) return Update::kRejected;
  Eigen::Vector2d h;
  Eigen::Matrix<double, 2, 3> J;
  measurementModel(R, t, y, &h, &J);
  if (std::sqrt(w * (xy - h).squaredNorm()) > params_.max_residual_sigmas) return Update::kRejected;
  // Covariance back-propagation (paper eq. 20): Lambda <- Lambda + J^T Lambda_z J at the new y.
  y_ = y;
  information_ += w * J.transpose() * J;
  ++num_updates_;
  return Update::kUpdated;
}

double InverseDepthFilter::relativeDepthSigma() const {
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(information_);
  if (!lu.isInvertible() || !(y_.z() > 0.0)) return std::numeric_limits<double>::infinity();
  const double variance_q = lu.inverse()(2, 2);
  if (!(variance_q > 0.0)) return std::numeric_limits<double>::infinity();
  return std::sqrt(variance_q) / y_.z();
}

bool InverseDepthFilter::isCertain() const {
  return num_updates_ >= params_.min_updates &&
         relativeDepthSigma() < params_.max_relative_depth_sigma;
}

Eigen::Vector3d InverseDepthFilter::pointInOrigin() const {
  return Eigen::Vector3d(y_.x(), y_.y(), 1.0) / y_.z();
}

Eigen::Vector3d InverseDepthFilter::pointInWorld() const {
  return T_origin_world_.inverse() * pointInOrigin();
}

void InverseDepthFilter::rescaleDepth(double s) {
  if (!(s > 0.0) || !std::isfinite(s)) {
    throw std::invalid_argument("inverse-depth filter: a depth scale must be positive");
  }
  y_.z() /= s;
  const Eigen::Vector3d D(1.0, 1.0, s);  // Lambda' = D Lambda D for y' = D^-1 y
  information_ = D.asDiagonal() * information_ * D.asDiagonal();
}

}  // namespace scale_drift_slam::tracking
