#include "scale_drift_slam/loop/appearance.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <opencv2/imgproc.hpp>

namespace scale_drift_slam::loop {

void KeyframeAppearance::validate() const {
  const auto fail = [](const std::string& reason) {
    throw std::invalid_argument("keyframe appearance: " + reason);
  };
  if (image_width <= 0 || image_height <= 0) fail("image size must be positive");
  if (octaves.size() != keypoints.size()) fail("octaves and keypoints differ in number");
  if (keypoints.empty()) {
    if (!descriptors.empty()) fail("descriptors without keypoints");
    return;
  }
  if (descriptors.type() != CV_8UC1 || descriptors.cols != kDescriptorBytes ||
      static_cast<std::size_t>(descriptors.rows) != keypoints.size()) {
    fail("descriptors must be a CV_8UC1 matrix of " + std::to_string(keypoints.size()) + " x " +
         std::to_string(kDescriptorBytes) + " bytes");
  }
  for (const cv::Point2f& p : keypoints) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) fail("a keypoint is not finite");
    if (!undistorted && !(p.x >= 0.0f && p.y >= 0.0f && p.x < image_width && p.y < image_height)) {
      fail("keypoint (" + std::to_string(p.x) + ", " + std::to_string(p.y) + ") outside the image");
    }
  }
}

AppearanceExtractor::AppearanceExtractor(const AppearanceParams& params) : params_(params) {
  params_.validate();
  // Over-detect three times the budget, then keep the strongest per grid cell (detectSpread).
  orb_ = cv::ORB::create(3 * params_.max_features, static_cast<float>(params_.scale_factor),
                         params_.pyramid_levels, params_.border, 0, 2, cv::ORB::HARRIS_SCORE, 31,
                         params_.fast_threshold);
}

std::vector<cv::KeyPoint> AppearanceExtractor::detectSpread(const cv::Mat& grey) {
  std::vector<cv::KeyPoint> detected;
  orb_->setFastThreshold(params_.fast_threshold);
  orb_->detect(grey, detected);
  if (static_cast<int>(detected.size()) < params_.max_features) {  // weak texture: lower it
    orb_->setFastThreshold(params_.min_fast_threshold);
    detected.clear();
    orb_->detect(grey, detected);
  }
  // Bucket into the grid, strongest first in each cell, then take one per cell per round.
  const int cols = params_.grid_cols;
  const int rows = params_.grid_rows;
  std::vector<std::vector<int>> cells(static_cast<std::size_t>(cols * rows));
  for (int i = 0; i < static_cast<int>(detected.size()); ++i) {
    const int cx = std::clamp(static_cast<int>(detected[i].pt.x * cols / grey.cols), 0, cols - 1);
    const int cy = std::clamp(static_cast<int>(detected[i].pt.y * rows / grey.rows), 0, rows - 1);
    cells[static_cast<std::size_t>(cy) * cols + cx].push_back(i);
  }
  for (std::vector<int>& cell : cells) {
    std::stable_sort(cell.begin(), cell.end(),
                     [&](int a, int b) { return detected[a].response > detected[b].response; });
  }
  std::vector<cv::KeyPoint> kept;
  kept.reserve(static_cast<std::size_t>(params_.max_features));
  for (std::size_t round = 0; static_cast<int>(kept.size()) < params_.max_features; ++round) {
    bool any = false;
    for (const std::vector<int>& cell : cells) {
      if (round >= cell.size()) continue;
      any = true;
      kept.push_back(detected[cell[round]]);
      if (static_cast<int>(kept.size()) == params_.max_features) break;
    }
    if (!any) break;
  }
  return kept;
}

KeyframeAppearance AppearanceExtractor::extract(const cv::Mat& image,
                                                const geometry::CameraModel* camera) {
  if (image.empty()) throw std::invalid_argument("appearance: empty image");
  if (image.depth() != CV_8U) throw std::invalid_argument("appearance: image must be 8-bit");
  cv::Mat grey;
  if (image.channels() == 1) {
    grey = image;
  } else if (image.channels() == 3) {
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  } else if (image.channels() == 4) {
    cv::cvtColor(image, grey, cv::COLOR_BGRA2GRAY);
  } else {
    throw std::invalid_argument("appearance: image must have 1, 3 or 4 channels");
  }
  if (grey.cols <= 2 * params_.border + 8 || grey.rows <= 2 * params_.border + 8) {
    throw std::invalid_argument("appearance: image " + std::to_string(grey.cols) + "x" +
                                std::to_string(grey.rows) + " too small for the border of " +
                                std::to_string(params_.border) + " px");
  }
  if (camera != nullptr && (camera->width() != grey.cols || camera->height() != grey.rows)) {
    throw std::invalid_argument("appearance: the camera is " + std::to_string(camera->width()) +
                                "x" + std::to_string(camera->height()) + ", the image " +
                                std::to_string(grey.cols) + "x" + std::to_string(grey.rows));
  }
  std::vector<cv::KeyPoint> keypoints = detectSpread(grey);
  KeyframeAppearance appearance;
  appearance.image_width = grey.cols;
  appearance.image_height = grey.rows;
  appearance.undistorted = camera != nullptr;
  if (keypoints.empty()) return appearance;
  orb_->compute(grey, keypoints, appearance.descriptors);
  appearance.keypoints.reserve(keypoints.size());
  appearance.octaves.reserve(keypoints.size());
  std::vector<int> kept;  // rows of the kept keypoints' descriptors
  kept.reserve(keypoints.size());
  for (std::size_t i = 0; i < keypoints.size(); ++i) {
    cv::Point2f pt = keypoints[i].pt;
    if (camera != nullptr) {
      // The ray through the pixel, then the ideal pinhole pixel: (fx x/z + cx, fy y/z + cy).
      const Eigen::Vector3d ray = camera->unproject(Eigen::Vector2d(pt.x, pt.y));
      if (ray.z() < 0.2 * ray.norm()) continue;  // beyond ~78 degrees: far off any plane
      const geometry::CameraCalibration& c = camera->calibration();
      pt = cv::Point2f(static_cast<float>(c.fx * ray.x() / ray.z() + c.cx),
                       static_cast<float>(c.fy * ray.y() / ray.z() + c.cy));
    }
    appearance.keypoints.push_back(pt);
    appearance.octaves.push_back(static_cast<std::uint8_t>(keypoints[i].octave));
    kept.push_back(static_cast<int>(i));
  }
  // Copied into a matrix of exactly their size: cv::Mat::push_back row by row over-allocates
  // by up to half, and the place-recognition database keeps every keyframe's descriptors.
  cv::Mat descriptors(static_cast<int>(kept.size()), appearance.descriptors.cols,
                      appearance.descriptors.type());
  for (std::size_t row = 0; row < kept.size(); ++row)
    appearance.descriptors.row(kept[row]).copyTo(descriptors.row(static_cast<int>(row)));
  appearance.descriptors = descriptors;
  if (appearance.descriptors.empty()) {
    appearance.keypoints.clear();
    appearance.octaves.clear();
  }
  return appearance;
}

}  // namespace scale_drift_slam::loop
