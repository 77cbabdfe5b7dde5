#pragma once
// Feature initialisation with inverse-depth information filters (doc/algorithm.md, "Front-end:
// feature initialisation with inverse-depth information filters", after Eade's framework).
//
// One filter per new feature, independent of the others given the (well optimised) current pose.
// State y = (u, v, q): the feature's normalised image location in its origin keyframe and its
// inverse depth, x_org = (u, v, 1) / q. Uncertainty as the information matrix Lambda, starting at
// diag(1/sigma^2, 1/sigma^2, 0): no depth prior, so points at any distance (q -> 0) can start.
// An update minimises (y - y_prior)^T Lambda (y - y_prior) + |z - h(y)|^2 / sigma^2 with LM, then
// Lambda += J^T J / sigma^2 (covariance back-propagation). Updates are gated by a parallax test.
// Owned by the tracker (one thread); a value type, cheap to copy.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/map/map.h"

namespace scale_drift_slam::tracking {

struct InverseDepthFilterParams {
  double pixel_sigma_px = 1.0;       ///< Measurement noise (standard deviation, pixels).
  double min_parallax_deg = 1.0;     ///< Update only when the parallax to the origin exceeds this.
  double max_residual_sigmas = 4.0;  ///< Reject an update leaving a larger residual (in sigmas).
  int max_iterations = 10;           ///< LM iterations per update.
  /// Certain enough for promotion: sigma(depth) / depth below this (sigma_q / q, first order).
  /// About 1 / (focal * parallax): 10 % asks for 0.8 degrees at a 718 px focal length. The window
  /// BA refines the point from then on; 5 % (1.6 degrees) starved the map of a car crossing an
  /// open junction, where what is left in view lies ahead, near the focus of expansion, and
  /// gains parallax slowly (doc/benchmarks.md, "Promotion certainty").
  double max_relative_depth_sigma = 0.1;
  int min_updates = 2;  ///< And at least this many accepted updates.
  /// Promotion: reject if the BA'd point reprojects worse than this in any keyframe (pixels).
  double max_promotion_error_px = 3.0;
  /// Throws std::invalid_argument naming the first bad value.
  void validate() const;
};

/// The rotation-compensated parallax (radians) between the origin ray of a feature and its ray in
/// the current camera: the angle between R_cur_org (u, v, 1) and (x, y, 1). Independent of the
/// unknown depth: pure rotation gives zero, translation gives the angle the baseline subtends.
double parallaxAngle(const Eigen::Matrix3d& R_cur_org, const Eigen::Vector2d& xy_origin,
                     const Eigen::Vector2d& xy_current);

/// A feature that keeps its pixel (within this many) between two views with parallax is taken
/// for texture fixed to the sensor: a saturated sensor's fixed pattern, dust on the lens, an
/// overlay burnt into the image. No point of the world keeps its pixel while the parallax
/// (rotation-compensated, above) says the view changed, except where the translation happens to
/// undo the rotation's image motion; texture fixed to the sensor does so at every pixel, and
/// triangulated there it becomes map points that hold the pose still.
constexpr double kSensorFixedPx = 1.0;

class InverseDepthFilter {
 public:
  enum class Update { kUpdated, kLowParallax, kRejected };

  /// A new feature seen at `xy_origin` (normalised) in keyframe `origin_id`.
  /// `initial_inverse_depth` is only the LM start value (its information is zero); 1 / (median
  /// scene depth) is a good one. Throws std::invalid_argument for non-finite input, q <= 0 or a
  /// non-positive focal length.
  InverseDepthFilter(map::KeyframeId origin_id, const geometry::SE3& T_origin_world,
                     const Eigen::Vector2d& xy_origin, double initial_inverse_depth,
                     double focal_length_px, const InverseDepthFilterParams& params);

  /// Filters one observation `xy` (normalised) in the camera T_cam_world. Returns kLowParallax
  /// (nothing changed) when the parallax test fails, kRejected (nothing changed) when the LM
  /// result leaves a residual above max_residual_sigmas or puts the point behind a camera.
  Update update(const geometry::SE3& T_cam_world, const Eigen::Vector2d& xy);

  /// Parallax of an observation against the origin (parallaxAngle with this filter's origin).
  double parallax(const geometry::SE3& T_cam_world, const Eigen::Vector2d& xy) const;

  /// sigma(q) / q from the information matrix; infinity while the depth is unobserved.
  double relativeDepthSigma() const;
  /// Certain enough (relativeDepthSigma, min_updates) to be considered for promotion.
  bool isCertain() const;

  Eigen::Vector3d pointInOrigin() const;  ///< (u, v, 1) / q.
  Eigen::Vector3d pointInWorld() const;
  const Eigen::Vector3d& state() const { return y_; }  ///< (u, v, q).
  const Eigen::Matrix3d& information() const { return information_; }
  map::KeyframeId originId() const { return origin_id_; }
  /// After the origin keyframe was re-optimised (window BA): the feature stays attached to it.
  void setOriginPose(const geometry::SE3& T_origin_world) { T_origin_world_ = T_origin_world; }
  const geometry::SE3& originPose() const { return T_origin_world_; }
  /// After a loop correction scaled the world around the origin by `s` (> 0): depth times s,
  /// q / s, and the information of q times s^2 (its uncertainty scales with it).
  void rescaleDepth(double s);
  int numUpdates() const { return num_updates_; }
  const InverseDepthFilterParams& params() const { return params_; }

 private:
  map::KeyframeId origin_id_;
  geometry::SE3 T_origin_world_;
  Eigen::Vector3d y_;
  Eigen::Matrix3d information_;
  double focal_length_px_;
  InverseDepthFilterParams params_;
  int num_updates_ = 0;
};

/// One keyframe that sees a feature about to be promoted.
struct PromotionView {
  map::KeyframeId keyframe_id = 0;
  geometry::SE3 T_kf_world;
  Eigen::Vector2d xy = Eigen::Vector2d::Zero();  ///< Normalised.
};

struct PromotionResult {
  bool accepted = false;
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
  std::vector<double> errors_px;  ///< Final reprojection error per view.
  std::string reason;             ///< Why it was rejected (empty when accepted).
  /// The views disagree with the filter's depth (a moving object, a mistracked feature): the
  /// feature will not become consistent by waiting.
  bool inconsistent = false;
};

/// The promotion rule (doc/algorithm.md, "Front-end: keyframe dropping"): a certain filter's
/// point is bundle adjusted (point only, LM from the filter's estimate) against a few (about
/// three) surrounding keyframes and rejected if it reprojects with more than
/// max_promotion_error_px in any of them, or lands behind one, or at a depth (in the filter's
/// origin) more than 10 times or less than a tenth of the filter's. Needs >= 2 views.
PromotionResult promoteFeature(const InverseDepthFilter& filter,
                               const std::vector<PromotionView>& views, double focal_length_px);

}  // namespace scale_drift_slam::tracking
