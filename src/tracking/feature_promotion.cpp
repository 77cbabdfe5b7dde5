// The promotion rule of inverse-depth features (doc/algorithm.md, "Front-end: keyframe
// dropping"): a point-only bundle adjustment against a few surrounding keyframes, then a check of
// the reprojection error in each.

#include <cmath>
#include <string>

#include "scale_drift_slam/features/reprojection_cost.h"
#include "scale_drift_slam/tracking/inverse_depth_filter.h"
#include "small_levenberg_marquardt.h"

namespace scale_drift_slam::tracking {
namespace {

/// The adjusted point's depth in the filter's origin may differ from the filter's by at most this
/// factor. With little parallax between the views the reprojection errors stay small all along
/// the ray, and the adjustment can run far out along it: on a feature of a moving car, whose
/// views do not meet at one point, to 1e7-1e8 map units (a two-hosts run promoted a point 2e7
/// away, which every receiver then refused with its keyframe). Such a feature is dropped, not
/// tried again (PromotionResult::inconsistent): it occupied a candidate's place where new ones
/// should spawn. The certain filter (sigma below 10 %) is rarely wrong by a factor of 10.
constexpr double kMaxDepthRatio = 10.0;

/// sum |f (z_k - proj(T_k x))|^2 and its Gauss-Newton system in the point x; infinity when x is
/// behind one of the cameras.
double pointCost(const std::vector<PromotionView>& views, const Eigen::Vector3d& x, double focal,
                 Eigen::Matrix3d* H, Eigen::Vector3d* g, std::vector<double>* errors) {
  double cost = 0.0;
  if (H != nullptr) H->setZero(), g->setZero();
  if (errors != nullptr) errors->clear();
  for (const PromotionView& view : views) {
    Eigen::Vector2d r;
    Eigen::Matrix<double, 2, 3> J;
    if (!features::reprojectionResidual(view.T_kf_world, x, view.xy, focal, &r, nullptr,
                                        H != nullptr ? &J : nullptr)) {
      return std::numeric_limits<double>::infinity();
    }
    cost += r.squaredNorm();
    if (errors != nullptr) errors->push_back(r.norm());
    if (H == nullptr) continue;
    *H += J.transpose() * J;
    *g += J.transpose() * r;
  }
  return cost;
}

}  // namespace

PromotionResult promoteFeature(const InverseDepthFilter& filter,
                               const std::vector<PromotionView>& views, double focal_length_px) {
  PromotionResult result;
  if (!(focal_length_px > 0.0)) throw std::invalid_argument("promotion: focal length must be > 0");
  if (views.size() < 2) {
    result.reason = "fewer than 2 keyframes see the feature";
    return result;
  }
  if (!(filter.state().z() > 0.0)) {
    result.reason = "the feature is at infinity";
    return result;
  }
  // Levenberg-Marquardt on the 3 coordinates, from the filter's estimate.
  Eigen::Vector3d x = filter.pointInWorld();
  internal::SmallLmOptions lm;
  lm.max_iterations = 10;
  lm.initial_damping = 1e-4;
  const double cost = internal::minimiseSmallLm(
      &x, lm, [&](const Eigen::Vector3d& p, Eigen::Matrix3d* H, Eigen::Vector3d* g) {
        return pointCost(views, p, focal_length_px, H, g, nullptr);
      });
  if (!std::isfinite(cost)) {
    result.reason = "the feature is behind a keyframe";
    return result;
  }
  const double q = 1.0 / (filter.originPose() * x).z();
  const double q_filter = filter.state().z();
  if (!(q > 0.0) || std::abs(std::log(q / q_filter)) > std::log(kMaxDepthRatio)) {
    result.reason = "the adjusted depth " + std::to_string(1.0 / q) + " is far from the filter's " +
                    std::to_string(1.0 / q_filter);
    result.inconsistent = true;
    return result;
  }
  pointCost(views, x, focal_length_px, nullptr, nullptr, &result.errors_px);
  result.p_world = x;
  for (std::size_t k = 0; k < result.errors_px.size(); ++k) {
    if (result.errors_px[k] > filter.params().max_promotion_error_px) {
      result.reason = "reprojection error " + std::to_string(result.errors_px[k]) +
                      " px in keyframe " + std::to_string(views[k].keyframe_id);
      return result;
    }
  }
  result.accepted = true;
  return result;
}

}  // namespace scale_drift_slam::tracking
