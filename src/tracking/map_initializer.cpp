#include "scale_drift_slam/tracking/map_initializer.h"

#include <algorithm>
#include <cstdio>
#include <stdexcept>

#include <Eigen/SVD>

#include "scale_drift_slam/common/statistics.h"
#include "scale_drift_slam/geometry/rolling_shutter_camera.h"
#include "scale_drift_slam/geometry/so3.h"

namespace scale_drift_slam::tracking {

void InitializerParams::validate() const {
  two_view.validate();
  if (num_features < two_view.min_points) {
    throw std::invalid_argument("initializer.num_features must be >= initializer.min_points");
  }
  if (min_tracks < two_view.min_points) {
    throw std::invalid_argument("initializer.min_tracks must be >= initializer.min_points");
  }
  if (!(min_disparity_px >= 0.0))
    throw std::invalid_argument("initializer.min_disparity_px must be >= 0");
  if (max_frames < 2) throw std::invalid_argument("initializer.max_frames must be >= 2");
}

namespace {

OpticalFlowParams initializerFlow(OpticalFlowParams params) {
  params.method = FlowMethod::kLucasKanade;
  params.max_forward_backward_px = 1.0;  // initial tracks must be clean: check both ways
  return params;
}

/// The rotation rate (rad/s) that turns the rays of `from` onto those of `to` over `interval`
/// (the least-squares rotation between the unit rays, by SVD): the camera's turn between two
/// frames, which dominates a rolling shutter's shear.
Eigen::Vector3d rotationRate(const std::vector<cv::Point2f>& from,
                             const std::vector<cv::Point2f>& to, double interval,
                             const geometry::CameraModel& camera) {
  if (from.size() < 3 || !(interval > 0.0)) return Eigen::Vector3d::Zero();
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < from.size(); ++i) {
    const Eigen::Vector3d a = camera.unproject(Eigen::Vector2d(from[i].x, from[i].y)).normalized();
    const Eigen::Vector3d b = camera.unproject(Eigen::Vector2d(to[i].x, to[i].y)).normalized();
    H += a * b.transpose();
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  const Eigen::Matrix3d R = svd.matrixV() * D * svd.matrixU().transpose();  // b = R a
  return geometry::logSO3(Eigen::Quaterniond(R)) / interval;
}

}  // namespace

MapInitializer::MapInitializer(std::shared_ptr<const geometry::CameraModel> camera,
                               const InitializerParams& params,
                               const features::FeatureDetectionParams& features,
                               const OpticalFlowParams& flow)
    : camera_(std::move(camera)),
      params_(params),
      features_(features),
      flow_(initializerFlow(flow)) {
  if (!camera_) throw std::invalid_argument("map initializer needs a camera model");
  params_.validate();
  features_.validate();
}

void MapInitializer::reset() {
  has_reference_ = false;
  reference_px_.clear();
  current_px_.clear();
}

void MapInitializer::startReference(double timestamp, const features::ImagePyramid& image) {
  const std::vector<cv::KeyPoint> corners =
      features::detectSpreadCorners(image, params_.num_features, features_);
  reference_px_.clear();
  for (const cv::KeyPoint& k : corners)
    reference_px_.push_back(k.pt);
  current_px_ = reference_px_;
  frames_since_reference_ = 0;
  reference_timestamp_ = timestamp;
  previous_timestamp_ = timestamp;
  reference_rate_ = current_rate_ = Eigen::Vector3d::Zero();
  reference_image_ = image;
  previous_image_ = image;
  has_reference_ = static_cast<int>(reference_px_.size()) >= params_.min_tracks;
  status_ =
      has_reference_
          ? "new reference frame with " + std::to_string(reference_px_.size()) + " corners"
          : "too few corners (" + std::to_string(reference_px_.size()) + ") for a reference frame";
}

std::optional<InitialMap> MapInitializer::addFrame(double timestamp,
                                                   const features::ImagePyramid& image) {
  if (!has_reference_) {
    startReference(timestamp, image);
    return std::nullopt;
  }
  std::vector<cv::Point2f> next;
  std::vector<unsigned char> ok;
  flow_.track(previous_image_, image, current_px_, &next, &ok);
  std::size_t kept = 0;
  std::vector<double> disparity;
  std::vector<cv::Point2f> step_from, step_to;
  for (std::size_t i = 0; i < next.size(); ++i) {
    if (!ok[i]) continue;
    step_from.push_back(current_px_[i]);
    step_to.push_back(next[i]);
    reference_px_[kept] = reference_px_[i];
    current_px_[kept] = next[i];
    const cv::Point2f d = next[i] - reference_px_[kept];
    disparity.push_back(std::sqrt(d.dot(d)));
    ++kept;
  }
  reference_px_.resize(kept);
  current_px_.resize(kept);
  previous_image_ = image;
  ++frames_since_reference_;
  if (camera_->calibration().rolling_shutter_readout_s > 0.0) {
    // The reference frame's rate is measured on the step after it.
    current_rate_ = rotationRate(step_from, step_to, timestamp - previous_timestamp_, *camera_);
    if (frames_since_reference_ == 1) reference_rate_ = current_rate_;
  }
  previous_timestamp_ = timestamp;
  if (static_cast<int>(kept) < params_.min_tracks || frames_since_reference_ > params_.max_frames) {
    const std::string why = "restarting (" + std::to_string(kept) + " tracks after " +
                            std::to_string(frames_since_reference_) + " frames): ";
    startReference(timestamp, image);
    status_ = why + status_;
    return std::nullopt;
  }
  const double median_disparity = common::upperMedian(std::move(disparity));
  if (median_disparity < params_.min_disparity_px) {
    status_ = "waiting for motion (median disparity " + std::to_string(median_disparity) + " px)";
    return std::nullopt;
  }
  // Each view's pixels as a global shutter at its stamp would see them (the camera itself for a
  // global shutter).
  const auto first_camera = geometry::turningFrameCamera(camera_, reference_rate_);
  const auto second_camera = geometry::turningFrameCamera(camera_, current_rate_);
  InitialMap map;
  for (std::size_t i = 0; i < kept; ++i) {
    map.px_first.emplace_back(reference_px_[i].x, reference_px_[i].y);
    map.px_second.emplace_back(current_px_[i].x, current_px_[i].y);
    map.xy_first.push_back(first_camera->undistortToNormalized(map.px_first.back()));
    map.xy_second.push_back(second_camera->undistortToNormalized(map.px_second.back()));
  }
  const double focal = camera_->calibration().meanFocalLength();
  TwoViewResult result = reconstructTwoView(map.xy_first, map.xy_second, focal, params_.two_view);
  if (!result.success) {
    status_ = "two-view reconstruction refused: " + result.reason;
    return std::nullopt;
  }
  map.first_timestamp = reference_timestamp_;
  map.T_second_first = result.T_second_first;
  map.p_first = std::move(result.points_first);
  map.triangulated = std::move(result.triangulated);
  map.first_image = reference_image_;
  map.used_homography = result.used_homography;
  map.second_camera = second_camera;
  char parallax[32];
  std::snprintf(parallax, sizeof(parallax), "%.1f", result.median_parallax_deg);
  status_ = "initialised from " + std::to_string(result.num_triangulated) + " points (" +
            (result.used_homography ? "homography" : "essential matrix") + ", median parallax " +
            parallax + " deg)";
  reset();
  return map;
}

}  // namespace scale_drift_slam::tracking
