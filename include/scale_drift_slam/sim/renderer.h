#pragma once
// A software rasteriser for textured planar scenes, exact to the camera model: every pixel is
// the surface hit by the ray that geometry::CameraModel::unproject gives for the pixel's centre
// (OpenCV convention: integer pixel coordinates are centres), so the ground-truth pose agrees with
// the pixels also under lens distortion. Z-buffered (front-to-back order, depth = range along the
// ray), perspective-correct (ray-plane intersection per pixel) and mip-mapped (trilinear, level of
// detail from the pixel's footprint on the surface).

#include <memory>
#include <vector>

#include <opencv2/core.hpp>

#include "scale_drift_slam/geometry/camera_model.h"
#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/sim/scene.h"

namespace scale_drift_slam::sim {

/// Renders scenes through one camera. Owns its per-pixel ray table and frame buffers, so one
/// instance is used by one thread at a time; make one per thread to render in parallel.
class Renderer {
 public:
  /// Precomputes the ray of every pixel. Throws std::invalid_argument when a pixel looks more
  /// than ~87 degrees away from the optical axis (the renderer covers less than a half sphere).
  explicit Renderer(const geometry::CameraModel& camera);

  /// Renders the scene seen by a camera at T_cam_world (world -> camera) as 8-bit grey. With a
  /// row range [row_begin, row_end) (row_end < 0: the last row) only those rows are rendered and
  /// the others of `image` (and of range() and surfaceIndex()) are kept: a rolling shutter
  /// renders each band of rows at its own pose.
  void render(const Scene& scene, const geometry::SE3& T_cam_world, cv::Mat& image,
              int row_begin = 0, int row_end = -1);
  /// The same in colour (BGR): the grey image tinted per surface (Surface::tint).
  void renderColor(const Scene& scene, const geometry::SE3& T_cam_world, cv::Mat& image,
                   int row_begin = 0, int row_end = -1);

  /// Of the last render: the range (metres along the ray) per pixel, +inf where no surface was
  /// hit (CV_32F), and the index of the surface seen per pixel, -1 for the background (CV_32S).
  cv::Mat range() const;
  const cv::Mat& surfaceIndex() const { return index_; }
  /// Of the last render: the point seen at pixel (x, y) in the camera frame (metres; not finite
  /// where no surface was hit).
  Eigen::Vector3f point(int x, int y) const;
  /// Shade 8 pixels at a time with AVX2 (default where the processor has it) or one at a time;
  /// both give the same images up to float rounding.
  void setVectorised(bool vectorised);
  bool vectorised() const { return vectorised_; }
  /// The unit ray (camera frame) through the centre of pixel (x, y).
  Eigen::Vector3f ray(int x, int y) const;

 private:
  struct Prepared;  // a surface in the camera frame, clipped, ready to rasterise

  bool prepare(const Surface& surface, const Scene& scene, const Eigen::Matrix3d& R,
               const Eigen::Vector3d& t, Prepared& out) const;
  void rasterise(const Prepared& surface, const Scene& scene, int rows_lo, int rows_hi,
                 cv::Mat& image);
  bool computeSpans(const Prepared& surface, int& row_begin, int& row_end);
  bool projectPoint(const Eigen::Vector3d& p_cam, Eigen::Vector2d& pixel) const;
  void appendEdge(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector2d& pa,
                  const Eigen::Vector2d& pb, int depth, std::vector<Eigen::Vector2d>& out) const;

  std::unique_ptr<geometry::CameraModel> camera_;  ///< Own copy of the model.
  bool linear_;                                    ///< No distortion: project with K alone.
  bool vectorised_;                                ///< Shade with AVX2 (span_shader.h).
  int width_, height_;
  std::vector<float> ray_x_, ray_y_, ray_z_;  ///< Unit ray per pixel (used by distorted cameras).
  std::vector<float> column_x_, row_y_;       ///< x/z per column, y/z per row (linear cameras).
  /// Per pixel log2(alpha) + 2 log2|r| for the ray r the rasteriser uses (unit for distorted
  /// cameras, z = 1 for linear ones), alpha the pixel's angular size; see Prepared.
  std::vector<float> lod_offset_;
  double x_min_, x_max_, y_min_, y_max_;  ///< Bounds of x/z and y/z over all rays (with margin).
  cv::Mat depth_;  ///< z for linear cameras, range along the ray for distorted ones.
  cv::Mat index_;
  std::vector<float> span_lo_, span_hi_;
  std::vector<Eigen::Vector2d> boundary_;
};

}  // namespace scale_drift_slam::sim
