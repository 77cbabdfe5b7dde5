#include "scale_drift_slam/sim/texture.h"

#include <stdexcept>

#include <opencv2/imgproc.hpp>

namespace scale_drift_slam::sim {

Texture::Texture(const cv::Mat& image) {
  if (image.type() != CV_8UC1) throw std::invalid_argument("a texture must be an 8-bit grey image");
  if (image.cols < 2 || image.rows < 2) throw std::invalid_argument("a texture needs at least 2x2");
  images_.push_back(image.clone());
  while (images_.back().cols >= 4 && images_.back().rows >= 4) {
    const cv::Mat& previous = images_.back();
    cv::Mat next;
    cv::resize(previous, next, cv::Size((previous.cols + 1) / 2, (previous.rows + 1) / 2), 0, 0,
               cv::INTER_AREA);
    images_.push_back(next);
  }
  for (const cv::Mat& m : images_) {
    cv::Mat padded;
    cv::copyMakeBorder(m, padded, 1, 1, 1, 1, cv::BORDER_REPLICATE);
    padded_.push_back(padded);
    Level level;
    level.data = padded.ptr<std::uint8_t>(1) + 1;
    level.stride = padded.step[0];
    level.scale_x = static_cast<float>(m.cols) / static_cast<float>(images_[0].cols);
    level.scale_y = static_cast<float>(m.rows) / static_cast<float>(images_[0].rows);
    levels_.push_back(level);
  }
  max_lod_ = static_cast<float>(levels_.size() - 1);
}

}  // namespace scale_drift_slam::sim
