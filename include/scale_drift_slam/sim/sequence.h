#pragma once
// Rendered image sequences with exact ground truth: a named scenario (sim/scenario.h) seen
// through a configurable camera, frame by frame, with the realism effects of RealismParams.
// Deterministic: a frame depends only on the parameters (including the seed) and its index.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "scale_drift_slam/geometry/camera_calibration.h"
#include "scale_drift_slam/geometry/camera_model.h"
#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/sim/camera_effects.h"
#include "scale_drift_slam/sim/renderer.h"
#include "scale_drift_slam/sim/scenario.h"

namespace scale_drift_slam::sim {

/// Image degradations, each off by default except a slight optical blur.
struct RealismParams {
  double noise_sigma = 0.0;         ///< Gaussian pixel noise, grey levels.
  double exposure_amplitude = 0.0;  ///< Brightness gain 1 + a sin(2 pi t / period), a in [0, 1).
  double exposure_period = 6.0;     ///< Seconds.
  double motion_blur = 0.0;         ///< Shutter time in seconds (0: none); the pose is mid-shutter.
  int motion_blur_samples = 6;      ///< Renders averaged over the shutter time.
  double optics_blur = 0.5;         ///< Gaussian blur sigma in pixels (lens softness; 0: none).
  double blackout_start = 0.0;      ///< Seconds after the first frame.
  double blackout_duration = 0.0;   ///< Frames in [start, start + duration) are black (0: none).
  // Camera effects (sim/camera_effects.h); any of them on renders through a float pipeline.
  double rolling_shutter = 0.0;   ///< Readout time, top row to bottom row, s (0: global shutter).
  int rolling_shutter_bands = 0;  ///< Bands of rows rendered at their own pose (0: every row).
  double vignetting = 0.0;        ///< Radial fall-off k: the corners get 1 - k of the light.
  bool auto_exposure = false;     ///< A lagging gain controller keeps the mean grey level.
  double sunlight = 1.0;          ///< Sunlit patches and sky this many times brighter (1: none).
  double defocus = 0.0;           ///< Radius of the circle of confusion, pixels (0: in focus).
  int jpeg_quality = 0;           ///< JPEG round trip at this quality, 1-100 (0: none).
  bool cameraEffects() const;     ///< Any of the camera effects on.
  void validate() const;          ///< Throws std::invalid_argument with the reason.
};

/// The parameters of the sim module: what to render and through which camera.
struct SequenceParams {
  std::string scene = "courtyard_loop";
  std::uint32_t seed = 1;
  int width = 640;
  int height = 480;
  double rate = 0.0;                ///< Frames per second; 0: the scenario's default.
  double horizontal_fov_deg = 0.0;  ///< 0: the scenario's default (120 for fisheye).
  /// none, radtan (plumb_bob, EuRoC-like), tum_fr1 (plumb_bob, strong radial, TUM RGB-D fr1's)
  /// or fisheye (equidistant); empty: the scenario's lens (Scenario::distortion).
  std::string distortion;
  int max_frames = 0;          ///< Render only the first frames (0: the whole trajectory).
  bool color = false;          ///< bgr8 images instead of mono8.
  double start_time = 1000.0;  ///< Stamp of the first frame, seconds.
  /// The scene (textures, layout) from this seed, the motion (wobble) and the noise from `seed`:
  /// another pass through the same place. Unset: both from `seed`.
  std::optional<std::uint32_t> scene_seed;
  /// The first frame is this far along the trajectory (a share of its duration, in [0, 1)); the
  /// sequence is that much shorter.
  double start_fraction = 0.0;
  int laps = 1;  ///< The route driven this many times (city_loop only; makeScenario()).
  /// The car's yaw rate in the turns, deg/s (city_* only; ScenarioOptions::turn_rate_deg_s).
  std::optional<double> turn_rate_deg_s;
  /// Moving cars in the streets (city_* scenes): from `seed`, clear of the camera's drive.
  bool traffic = false;
  RealismParams realism;
  void validate() const;  ///< Throws std::invalid_argument with the reason.
};

/// One frame: its stamp (exact integer nanoseconds and the same in seconds), the true camera pose
/// in the world at that stamp, and the image (CV_8UC1, or CV_8UC3 BGR when colour).
struct RenderedFrame {
  int index = 0;
  std::int64_t stamp_ns = 0;
  double timestamp = 0.0;
  geometry::SE3 T_world_cam;
  cv::Mat image;
};

/// Builds the scenario and the camera once, then renders frames on demand. Owns the scene, the
/// camera model and a renderer; one thread at a time.
class SequenceRenderer {
 public:
  /// Validates the parameters and builds the scene (throws std::invalid_argument, e.g. for an
  /// unknown scene name).
  explicit SequenceRenderer(const SequenceParams& params);

  int frameCount() const { return frame_count_; }
  double rate() const { return rate_; }
  const geometry::CameraCalibration& calibration() const { return camera_->calibration(); }
  const geometry::CameraModel& camera() const { return *camera_; }
  const Scenario& scenario() const { return scenario_; }
  const SequenceParams& params() const { return params_; }

  /// Renders frame `index` (0 <= index < frameCount()); throws std::out_of_range otherwise. With
  /// auto-exposure a frame's gain depends on the frames before it: rendering in order costs
  /// nothing extra, a frame further ahead replays the controller over the frames between.
  RenderedFrame render(int index);
  /// The true pose and stamp of frame `index` without rendering it.
  RenderedFrame pose(int index) const;

 private:
  cv::Mat renderAt(double t);
  bool blackout(double t) const;
  cv::Mat cameraImage(int index, double t);
  cv::Mat sensorRadiance(double t);
  double autoExposureGain(int index, const cv::Mat& radiance);
  void meterFrame(int index, const cv::Mat& radiance);

  SequenceParams params_;
  Scenario scenario_;
  std::unique_ptr<geometry::CameraModel> camera_;
  std::unique_ptr<Renderer> renderer_;
  double rate_ = 30.0;
  int frame_count_ = 0;
  double exposure_phase_ = 0.0;
  std::unique_ptr<Sunlight> sunlight_;  ///< With RealismParams::sunlight != 1.
  AutoExposure auto_exposure_;
  std::vector<double> exposure_gains_;  ///< Auto-exposure gain of frames 0, 1, ... so far.
};

/// The camera of a sequence: size, field of view and lens model as in SequenceParams (the
/// focal length follows from the horizontal field of view as for an undistorted camera;
/// radtan uses EuRoC-like coefficients, tum_fr1 TUM RGB-D fr1's, fisheye TUM-VI-like ones; an
/// empty distortion is none).
geometry::CameraCalibration sequenceCalibration(const SequenceParams& params,
                                                double default_fov_deg);

}  // namespace scale_drift_slam::sim
