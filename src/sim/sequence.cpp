#include "scale_drift_slam/sim/sequence.h"

#include <cmath>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

namespace scale_drift_slam::sim {
namespace {

void require(bool condition, const std::string& reason) {
  if (!condition) throw std::invalid_argument(reason);
}

}  // namespace

void RealismParams::validate() const {
  require(std::isfinite(noise_sigma) && noise_sigma >= 0 && noise_sigma <= 100,
          "noise sigma must be in [0, 100] grey levels");
  require(std::isfinite(exposure_amplitude) && exposure_amplitude >= 0 && exposure_amplitude < 1,
          "exposure amplitude must be in [0, 1)");
  require(std::isfinite(exposure_period) && exposure_period > 0, "exposure period must be > 0 s");
  require(std::isfinite(motion_blur) && motion_blur >= 0 && motion_blur <= 1,
          "motion blur (shutter time) must be in [0, 1] s");
  require(motion_blur_samples >= 1 && motion_blur_samples <= 64,
          "motion blur samples must be in [1, 64]");
  require(std::isfinite(optics_blur) && optics_blur >= 0 && optics_blur <= 10,
          "optics blur must be in [0, 10] pixels");
  require(std::isfinite(blackout_start) && blackout_start >= 0, "blackout start must be >= 0 s");
  require(std::isfinite(blackout_duration) && blackout_duration >= 0,
          "blackout duration must be >= 0 s");
  require(std::isfinite(rolling_shutter) && rolling_shutter >= 0 && rolling_shutter <= 1,
          "rolling shutter readout time must be in [0, 1] s");
  require(rolling_shutter_bands >= 0 && rolling_shutter_bands <= 8192,
          "rolling shutter bands must be in [0, 8192] (0: every row)");
  require(std::isfinite(vignetting) && vignetting >= 0 && vignetting < 1,
          "vignetting must be in [0, 1)");
  require(std::isfinite(sunlight) && sunlight >= 1 && sunlight <= 20,
          "sunlight must be in [1, 20] times the shade");
  require(std::isfinite(defocus) && defocus >= 0 && defocus <= 20,
          "defocus radius must be in [0, 20] pixels");
  require(jpeg_quality >= 0 && jpeg_quality <= 100, "JPEG quality must be in [1, 100] (0: off)");
}

bool RealismParams::cameraEffects() const {
  return rolling_shutter > 0 || vignetting > 0 || auto_exposure || sunlight != 1.0 || defocus > 0 ||
         jpeg_quality > 0;
}

void SequenceParams::validate() const {
  require(width >= 16 && width <= 8192 && height >= 16 && height <= 8192,
          "image size must be between 16 and 8192 pixels");
  require(std::isfinite(rate) && rate >= 0 && rate <= 1000, "frame rate must be in (0, 1000] Hz");
  require(std::isfinite(horizontal_fov_deg) &&
              (horizontal_fov_deg == 0 || (horizontal_fov_deg >= 10 && horizontal_fov_deg <= 160)),
          "horizontal field of view must be in [10, 160] degrees");
  require(distortion.empty() || distortion == "none" || distortion == "radtan" ||
              distortion == "tum_fr1" || distortion == "fisheye",
          "distortion must be none, radtan, tum_fr1 or fisheye, not '" + distortion + "'");
  require(max_frames >= 0, "the number of frames must be >= 0");
  require(start_fraction >= 0.0 && start_fraction < 1.0, "start fraction must be in [0, 1)");
  require(laps >= 1 && laps <= 100, "laps must be in [1, 100]");
  require(std::isfinite(start_time) && start_time >= 0 && start_time < 4e9,
          "start time must be in [0, 4e9) s");
  realism.validate();
}

geometry::CameraCalibration sequenceCalibration(const SequenceParams& params,
                                                double default_fov_deg) {
  geometry::CameraCalibration c;
  c.rolling_shutter_readout_s = params.realism.rolling_shutter;  // rows rendered as it says
  c.width = params.width;
  c.height = params.height;
  c.cx = (params.width - 1) / 2.0;
  c.cy = (params.height - 1) / 2.0;
  double fov = params.horizontal_fov_deg > 0 ? params.horizontal_fov_deg : default_fov_deg;
  if (params.distortion == "fisheye") {
    if (params.horizontal_fov_deg == 0) fov = 120.0;
    c.model = geometry::DistortionModel::kEquidistant;
    c.fx = c.fy = (params.width / 2.0) / (0.5 * fov * M_PI / 180.0);  // r = f theta
    c.distortion = {0.0034823, 0.000715, -0.0020532, 0.0002029};      // TUM-VI-like
  } else {
    c.model = geometry::DistortionModel::kRadialTangential;
    c.fx = c.fy = (params.width / 2.0) / std::tan(0.5 * fov * M_PI / 180.0);
    if (params.distortion == "radtan") {
      c.distortion = {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 0.0};  // EuRoC cam0
    } else if (params.distortion == "tum_fr1") {
      // TUM RGB-D freiburg1 (Kinect): strong radial terms of alternating sign, |k2| ~ 1.
      c.distortion = {0.2624, -0.9531, -0.0054, 0.0026, 1.1633};
    } else {
      c.distortion = {0.0, 0.0, 0.0, 0.0, 0.0};
    }
  }
  c.validate();
  return c;
}

SequenceRenderer::SequenceRenderer(const SequenceParams& params) : params_(params) {
  params_.validate();
  ScenarioOptions options;
  options.traffic = params_.traffic;
  options.traffic_seed = params_.seed;
  options.motion_seed = params_.seed;
  options.laps = params_.laps;
  options.turn_rate_deg_s = params_.turn_rate_deg_s;
  scenario_ = makeScenario(params_.scene, params_.scene_seed.value_or(params_.seed), options);
  if (params_.scene_seed && *params_.scene_seed != params_.seed) {
    // The same place, walked with another wobble: the motion of the scenario of `seed`.
    ScenarioOptions drive;
    drive.laps = params_.laps;
    drive.turn_rate_deg_s = params_.turn_rate_deg_s;
    scenario_.T_world_cam = makeScenario(params_.scene, params_.seed, drive).T_world_cam;
  }
  if (params_.start_fraction > 0.0) {
    const double offset = params_.start_fraction * scenario_.duration;
    scenario_.T_world_cam = [motion = scenario_.T_world_cam, offset](double t) {
      return motion(t + offset);
    };
    if (scenario_.animate) {
      scenario_.animate = [animate = scenario_.animate, offset](double t, Scene& scene) {
        animate(t + offset, scene);
      };
      scenario_.moving_objects = [objects = scenario_.moving_objects, offset](double t) {
        return objects(t + offset);
      };
    }
    scenario_.duration -= offset;
  }
  if (params_.distortion.empty()) params_.distortion = scenario_.distortion;
  camera_ = geometry::makeCameraModel(sequenceCalibration(params_, scenario_.horizontal_fov_deg));
  renderer_ = std::make_unique<Renderer>(*camera_);
  rate_ = params_.rate > 0 ? params_.rate : scenario_.rate;
  frame_count_ = static_cast<int>(std::floor(scenario_.duration * rate_ + 1e-9));
  if (params_.max_frames > 0) frame_count_ = std::min(frame_count_, params_.max_frames);
  cv::RNG rng(params_.seed * 7919ULL + 17);
  exposure_phase_ = rng.uniform(0.0, 2.0 * M_PI);
  if (params_.realism.sunlight != 1.0) {
    sunlight_ = std::make_unique<Sunlight>(params_.seed, params_.realism.sunlight);
  }
}

RenderedFrame SequenceRenderer::pose(int index) const {
  if (index < 0 || index >= frame_count_) {
    throw std::out_of_range("frame " + std::to_string(index) + " outside [0, " +
                            std::to_string(frame_count_) + ")");
  }
  RenderedFrame frame;
  frame.index = index;
  frame.stamp_ns = std::llround(params_.start_time * 1e9) + std::llround(index * 1e9 / rate_);
  frame.timestamp = static_cast<double>(frame.stamp_ns) * 1e-9;
  frame.T_world_cam = scenario_.T_world_cam(index / rate_);
  return frame;
}

cv::Mat SequenceRenderer::renderAt(double t) {
  // A rolling shutter reads row y out at t + readout ((y + 0.5) / height - 0.5): the middle row
  // at the frame's stamp, where the ground truth is. Each band of rows is rendered at the exact
  // pose of its middle row's time.
  const int height = params_.height;
  const double readout = params_.realism.rolling_shutter;
  const int bands_wanted = params_.realism.rolling_shutter_bands;
  const int bands = readout > 0 ? (bands_wanted > 0 ? std::min(bands_wanted, height) : height) : 1;
  cv::Mat image, radiance;
  for (int b = 0; b < bands; ++b) {
    const cv::Range rows(b * height / bands, (b + 1) * height / bands);
    const double t_rows = t + readout * ((rows.start + rows.end) / (2.0 * height) - 0.5);
    const geometry::SE3 T_world_cam = scenario_.T_world_cam(std::max(0.0, t_rows));
    if (scenario_.animate) scenario_.animate(std::max(0.0, t_rows), scenario_.scene);
    const geometry::SE3 T_cam_world = T_world_cam.inverse();
    if (params_.color) {
      renderer_->renderColor(scenario_.scene, T_cam_world, image, rows.start, rows.end);
    } else {
      renderer_->render(scenario_.scene, T_cam_world, image, rows.start, rows.end);
    }
    if (sunlight_) sunlight_->apply(*renderer_, T_world_cam, image, rows, radiance);
  }
  return sunlight_ ? radiance : image;
}

bool SequenceRenderer::blackout(double t) const {
  const RealismParams& realism = params_.realism;
  return realism.blackout_duration > 0 && t >= realism.blackout_start &&
         t < realism.blackout_start + realism.blackout_duration;
}

cv::Mat SequenceRenderer::sensorRadiance(double t) {
  // The light on the sensor (CV_32F): shutter (motion blur), lens (defocus, softness, vignetting)
  // and the scene's brightness change, before the exposure gain.
  const RealismParams& realism = params_.realism;
  const int n = realism.motion_blur > 0 ? realism.motion_blur_samples : 1;
  cv::Mat radiance = cv::Mat::zeros(params_.height, params_.width, CV_32FC(params_.color ? 3 : 1));
  for (int k = 0; k < n; ++k) {
    const double offset = n > 1 ? realism.motion_blur * ((k + 0.5) / n - 0.5) : 0.0;
    cv::accumulate(renderAt(std::max(0.0, t + offset)), radiance);
  }
  radiance /= n;
  applyDefocus(radiance, realism.defocus);
  if (realism.optics_blur > 0) {
    cv::GaussianBlur(radiance, radiance, cv::Size(0, 0), realism.optics_blur);
  }
  applyVignetting(radiance, realism.vignetting);
  radiance *= 1.0 + realism.exposure_amplitude *
                        std::sin(2 * M_PI * t / realism.exposure_period + exposure_phase_);
  return radiance;
}

double SequenceRenderer::autoExposureGain(int index, const cv::Mat& radiance) {
  // A frame's gain follows from the frames before it. Rendered in order (the normal case), each
  // frame meters itself for the next; a frame further ahead replays the frames in between.
  if (exposure_gains_.empty()) {
    auto_exposure_.settle(index == 0 ? radiance
                                     : (blackout(0.0) ? cv::Mat() : sensorRadiance(0.0)));
    exposure_gains_.push_back(auto_exposure_.gain());
  }
  while (static_cast<int>(exposure_gains_.size()) <= index) {
    const int j = static_cast<int>(exposure_gains_.size()) - 1;
    meterFrame(j, blackout(j / rate_) ? cv::Mat() : sensorRadiance(j / rate_));
  }
  const double gain = exposure_gains_[static_cast<size_t>(index)];
  if (static_cast<int>(exposure_gains_.size()) == index + 1) meterFrame(index, radiance);
  return gain;
}

void SequenceRenderer::meterFrame(int index, const cv::Mat& radiance) {
  auto_exposure_.setGain(exposure_gains_[static_cast<size_t>(index)]);
  if (!radiance.empty()) auto_exposure_.meter(radiance, 1.0 / rate_);  // dark: the gain holds
  exposure_gains_.push_back(auto_exposure_.gain());
}

cv::Mat SequenceRenderer::cameraImage(int index, double t) {
  const RealismParams& realism = params_.realism;
  const int type = params_.color ? CV_8UC3 : CV_8UC1;
  cv::Mat radiance = blackout(t) ? cv::Mat() : sensorRadiance(t);
  if (realism.auto_exposure) {
    const double gain = autoExposureGain(index, radiance);
    if (!radiance.empty()) radiance *= gain;
  }
  if (radiance.empty()) return cv::Mat::zeros(params_.height, params_.width, type);
  if (realism.noise_sigma > 0) {
    cv::Mat noise(radiance.size(), radiance.type());
    cv::RNG rng(params_.seed * 1000003ULL + static_cast<std::uint64_t>(index) * 7777ULL + 1);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, realism.noise_sigma);
    radiance += noise;
  }
  cv::Mat image;
  radiance.convertTo(image, type);  // saturates: highlights clip at 255
  if (realism.jpeg_quality > 0) image = jpegRoundTrip(image, realism.jpeg_quality);
  return image;
}

RenderedFrame SequenceRenderer::render(int index) {
  RenderedFrame frame = pose(index);
  const RealismParams& realism = params_.realism;
  const double t = index / rate_;
  if (realism.cameraEffects()) {
    frame.image = cameraImage(index, t);
    return frame;
  }
  const int type = params_.color ? CV_8UC3 : CV_8UC1;
  if (blackout(t)) {
    frame.image = cv::Mat::zeros(params_.height, params_.width, type);
  } else if (realism.motion_blur > 0 && realism.motion_blur_samples > 1) {
    cv::Mat sum = cv::Mat::zeros(params_.height, params_.width, CV_32FC(CV_MAT_CN(type)));
    const int n = realism.motion_blur_samples;
    for (int k = 0; k < n; ++k) {
      const double offset = realism.motion_blur * ((k + 0.5) / n - 0.5);
      cv::accumulate(renderAt(std::max(0.0, t + offset)), sum);
    }
    sum.convertTo(frame.image, type, 1.0 / n);
  } else {
    frame.image = renderAt(t);
  }
  if (realism.optics_blur > 0) {
    cv::GaussianBlur(frame.image, frame.image, cv::Size(0, 0), realism.optics_blur);
  }
  const double gain = 1.0 + realism.exposure_amplitude *
                                std::sin(2 * M_PI * t / realism.exposure_period + exposure_phase_);
  if (realism.noise_sigma > 0 || gain != 1.0) {
    cv::Mat as_float;
    frame.image.convertTo(as_float, CV_32F, gain);
    if (realism.noise_sigma > 0) {
      cv::Mat noise(as_float.size(), as_float.type());
      cv::RNG rng(params_.seed * 1000003ULL + static_cast<std::uint64_t>(index) * 7777ULL + 1);
      rng.fill(noise, cv::RNG::NORMAL, 0.0, realism.noise_sigma);
      as_float += noise;
    }
    as_float.convertTo(frame.image, type);
  }
  return frame;
}

}  // namespace scale_drift_slam::sim
