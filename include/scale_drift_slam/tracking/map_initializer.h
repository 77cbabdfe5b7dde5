#pragma once
// Automatic map initialisation from the first frames of a sequence (doc/algorithm.md,
// "Front-end"): corners of a reference frame are tracked frame to frame with pyramidal
// Lucas-Kanade; once they have moved enough, reconstructTwoView (two_view_reconstruction.h)
// tries to build the initial map. A refusal (too little parallax, pure rotation, ambiguity) just
// waits for more motion; when too few tracks survive or too many frames pass, the reference is
// replaced by the current frame. With a rolling shutter each of the two views is measured as a
// global shutter at its stamp would see it (geometry::RollingShutterCamera), from the rotation
// rate of its frame-to-frame tracks: a view taken as the camera starts to pan is sheared unlike
// the still one before it. Owned and run by the tracking thread.

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "scale_drift_slam/features/feature_detection.h"
#include "scale_drift_slam/features/image_preparation.h"
#include "scale_drift_slam/geometry/camera_model.h"
#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/tracking/optical_flow.h"
#include "scale_drift_slam/tracking/two_view_reconstruction.h"

namespace scale_drift_slam::tracking {

struct InitializerParams {
  TwoViewParams two_view;
  int num_features = 500;  ///< Corners tracked from the reference frame.
  int min_tracks = 80;     ///< Below this many surviving tracks, start again.
  /// Median corner motion before a reconstruction is tried: only skips a camera that has not
  /// moved beyond tracking jitter. Not a parallax test (the two-view's is): a hand-held camera
  /// turning towards what it looks at moves the corners little while the baseline grows.
  double min_disparity_px = 5.0;
  int max_frames = 60;  ///< Replace the reference after this many frames.
  void validate() const;
};

/// The two views the map starts from. The first view is the world frame; the scale is median
/// depth 1 in it. Per correspondence: raw pixels, normalised coordinates and (where
/// `triangulated`) the point.
struct InitialMap {
  double first_timestamp = 0.0;
  geometry::SE3 T_second_first;
  std::vector<Eigen::Vector2d> px_first, px_second;
  std::vector<Eigen::Vector2d> xy_first, xy_second;
  std::vector<Eigen::Vector3d> p_first;
  std::vector<bool> triangulated;
  features::ImagePyramid first_image;
  bool used_homography = false;
  /// The camera that measured the second view: a rolling shutter turning at the rate its tracks
  /// measured (the camera itself for a global shutter).
  std::shared_ptr<const geometry::CameraModel> second_camera;
};

class MapInitializer {
 public:
  /// `flow` gives the Lucas-Kanade window and levels (the pyramids are padded for that window);
  /// the initializer always uses Lucas-Kanade with a forward-backward check.
  MapInitializer(std::shared_ptr<const geometry::CameraModel> camera,
                 const InitializerParams& params, const features::FeatureDetectionParams& features,
                 const OpticalFlowParams& flow = {});

  /// Feeds the next frame; returns the initial map once two views reconstruct.
  std::optional<InitialMap> addFrame(double timestamp, const features::ImagePyramid& image);
  /// Starts over with the next frame as the reference.
  void reset();
  /// Why the last frame did not initialise (for logs).
  const std::string& status() const { return status_; }
  int numTracks() const { return static_cast<int>(current_px_.size()); }

 private:
  void startReference(double timestamp, const features::ImagePyramid& image);

  std::shared_ptr<const geometry::CameraModel> camera_;
  InitializerParams params_;
  features::FeatureDetectionParams features_;
  OpticalFlow flow_;
  bool has_reference_ = false;
  double reference_timestamp_ = 0.0;
  features::ImagePyramid reference_image_, previous_image_;
  std::vector<cv::Point2f> reference_px_, current_px_;
  int frames_since_reference_ = 0;
  double previous_timestamp_ = 0.0;
  /// The camera's rotation rate (rad/s, see geometry::RollingShutterCamera) at the reference
  /// frame and at the latest one, measured from their frame-to-frame tracks: a rolling shutter's
  /// rows are measured from the camera turning at these rates (zero for a global shutter).
  Eigen::Vector3d reference_rate_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d current_rate_ = Eigen::Vector3d::Zero();
  std::string status_ = "no frame yet";
};

}  // namespace scale_drift_slam::tracking
