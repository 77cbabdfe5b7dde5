#pragma once
// Active search for map points in a new frame (doc/algorithm.md, "Front-end: tracking one
// frame", step 3): predict each point's pixel from the prior pose T^(0), bound the search region
// by the innovation covariance Sigma_z = J Sigma_Delta J^T + sigma^2 I (J = d pixel / d pose,
// Sigma_Delta the prior's uncertainty), warp the point's template from its reference keyframe
// into the current view, and match it by normalised cross-correlation (NCC) at the FAST corners
// inside the region (and at the prediction itself), refined to sub-pixel by a parabola through
// the NCC scores. Pure functions; called by the tracking thread.
// The corners may come from the half-resolution level (detectSearchCorners): a corner is then
// only a seed within a pixel or two of its full-resolution position, and the best seeds climb
// one pixel at a time to their local NCC maximum before the parabola.

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "scale_drift_slam/features/feature_detection.h"
#include "scale_drift_slam/features/image_preparation.h"
#include "scale_drift_slam/geometry/camera_model.h"
#include "scale_drift_slam/geometry/se3.h"

namespace scale_drift_slam::features {

struct ActiveSearchParams {
  int template_radius = 4;           ///< Template of (2r+1)^2 pixels.
  double min_ncc = 0.8;              ///< Accept a match above this score.
  double gate_chi2 = 9.21;           ///< Mahalanobis gate of the region (99% of chi2, 2 dof).
  double pixel_sigma_px = 1.0;       ///< sigma of the image measurement in Sigma_z.
  double min_radius_px = 3.0;        ///< The region is at least this large...
  double max_radius_px = 40.0;       ///< ...and at most this.
  int fast_threshold = 8;            ///< FAST threshold of the candidate corners in a frame.
  double max_scale_change = 3.0;     ///< Skip points seen this much larger/smaller than in the ref.
  double max_view_angle_deg = 60.0;  ///< Skip points seen this far off their reference direction.
  int max_points = 300;  ///< Match at most this many visible points, spread over the image.
  /// The search corners come from pyramid level 1 (a quarter of the pixels to detect in; each
  /// match then climbs to the NCC peak at full resolution) when level 1 has at least this many
  /// FAST corners per 1000 pixels of the full-resolution frame; from level 0 otherwise (a frame
  /// whose texture is too fine or too faint for level 1 keeps every corner).
  double min_coarse_corner_density = 1.5;
  void validate() const;
};

/// A point's appearance, cut from its reference keyframe at creation: square patches around its
/// pixel at pyramid levels 0 and 1, and where they sit. The tracker keeps one per map point for
/// the whole run, so that a revisit finds the point again (issue 18, memory per keyframe): a
/// point the tracker has not searched for a while is stored compressed, 4 bits per pixel over
/// each patch's own grey-level range (compress()), and expanded again before it is searched.
class PointAppearance {
 public:
  static constexpr int kPatchRadius = 10;  ///< Patches of 21 x 21 pixels.
  static constexpr int kPatchSide = 2 * kPatchRadius + 1;
  static constexpr int kLevels = 2;
  static constexpr int kPatchPixels = kPatchSide * kPatchSide;
  Eigen::Vector2d px_reference = Eigen::Vector2d::Zero();  ///< Level-0 pixel in the reference.

  /// Cuts the patches around `px` from `image`. Returns false (and is empty) when too close to
  /// the border.
  bool cut(const ImagePyramid& image, const Eigen::Vector2d& px);
  /// Sets the patches (CV_8UC1, kPatchSide x kPatchSide each, or both empty: no appearance).
  /// Throws std::invalid_argument on another type or size.
  void setPatches(const cv::Mat& level0, const cv::Mat& level1);
  /// The patch of `level` (0 or 1), CV_8UC1, kPatchSide x kPatchSide: a read-only view of this
  /// object's pixels (valid while it lives and is not compressed or expanded), or a decoded copy
  /// when compressed; empty when nothing was cut.
  cv::Mat patch(int level) const;
  bool empty() const { return pixels_.empty(); }

  /// Keeps the pixels at 4 bits each, quantised between each patch's darkest and brightest
  /// pixel (half the memory; the error is at most 1/30 of that range). Idempotent.
  void compress();
  /// Back to 8 bits per pixel (the quantised values: compression is lossy). Idempotent.
  void expand();
  bool compressed() const { return compressed_; }
  /// Bytes of pixels held (for the memory figures).
  std::size_t pixelBytes() const { return pixels_.capacity(); }

 private:
  std::vector<std::uint8_t> pixels_;  ///< Levels 0 and 1, row by row; packed when compressed.
  std::array<std::uint8_t, kLevels> low_{};  ///< Compressed: the darkest pixel of each level...
  std::array<float, kLevels> step_{};        ///< ...and the grey-level step of one code.
  bool compressed_ = false;
};

/// What active search needs of one map point.
struct SearchPoint {
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
  geometry::SE3 T_ref_world;  ///< Pose of the keyframe the appearance was cut from.
  const PointAppearance* appearance = nullptr;
};

struct SearchMatch {
  bool found = false;
  Eigen::Vector2d px = Eigen::Vector2d::Zero();  ///< Measured pixel (raw image).
  Eigen::Vector2d xy = Eigen::Vector2d::Zero();  ///< Undistorted normalised coordinates.
  Eigen::Vector2d predicted_px = Eigen::Vector2d::Zero();
  double ncc = -1.0;
  bool visible = false;   ///< Predicted inside the image and in a viewable range.
  bool searched = false;  ///< Its template was matched (visible and within max_points).
  // A visible point may be left unsearched when more than max_points are visible.
};

/// The affine map taking pixel offsets around the point's projection in the current camera to
/// pixel offsets around its projection in the reference camera, for the plane through the point
/// parallel to the reference image plane: A_ref_cur = (J_cur R_cur_ref[:, 0:2] J_ref2^-1)^-1,
/// J the camera's projection Jacobians, J_ref2 its first two columns.
Eigen::Matrix2d referenceWarp(const geometry::CameraModel& camera, const Eigen::Vector3d& p_ref,
                              const Eigen::Vector3d& p_cur, const geometry::SE3& T_cur_ref);

/// Searches every point; `corners` are the FAST corners of the current frame (see
/// detectSearchCorners). Sigma_Delta is the 6x6 covariance of the prior pose in the left-update
/// tangent (omega, upsilon).
std::vector<SearchMatch> activeSearch(const std::vector<SearchPoint>& points,
                                      const geometry::SE3& T_cur_world_prior,
                                      const Eigen::Matrix<double, 6, 6>& Sigma_Delta,
                                      const geometry::CameraModel& camera,
                                      const ImagePyramid& image, const CornerGrid& corners,
                                      const ActiveSearchParams& params);

/// The FAST corners of a frame for active search, bucketed for region queries, in level-0
/// pixels: from pyramid level 1 (CornerGrid::level() 1) when it holds at least
/// params.min_coarse_corner_density corners per 1000 pixels of the frame, else from level 0.
CornerGrid detectSearchCorners(const ImagePyramid& image, const ActiveSearchParams& params);

/// NCC of two equally sized float patches, in [-1, 1]; -1 when either has no texture.
double normalizedCrossCorrelation(const float* a, const float* b, int n);

}  // namespace scale_drift_slam::features
