#include "scale_drift_slam/sim/texture.h"

#include <cstring>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

namespace scale_drift_slam::sim {

Texture::Texture(const cv::Mat& image) {
  if (image.type() != CV_8UC1) throw std::invalid_argument("a texture must be an 8-bit grey image");
  if (image.cols < 2 || image.rows < 2) throw std::invalid_argument("a texture needs at least 2x2");
  if (static_cast<double>(image.cols) * image.rows > (1 << 30)) {
    throw std::invalid_argument("a texture may have at most 2^30 texels");
  }
  images_.push_back(image.clone());
  while (images_.back().cols >= 4 && images_.back().rows >= 4 &&
         static_cast<int>(images_.size()) < kMaxLevels) {
    const cv::Mat& previous = images_.back();
    cv::Mat next;
    cv::resize(previous, next, cv::Size((previous.cols + 1) / 2, (previous.rows + 1) / 2), 0, 0,
               cv::INTER_AREA);
    images_.push_back(next);
  }
  size_t size = 0;
  for (const cv::Mat& m : images_)
    size += static_cast<size_t>(m.cols + 2) * (m.rows + 2);
  pool_.assign(size + 8, 0);
  size_t start = 0;
  for (size_t l = 0; l < images_.size(); ++l) {
    const cv::Mat& m = images_[l];
    const int stride = m.cols + 2;
    cv::Mat padded(m.rows + 2, stride, CV_8U, &pool_[start]);
    cv::copyMakeBorder(m, padded, 1, 1, 1, 1, cv::BORDER_REPLICATE);
    layout_.offset[l] = static_cast<std::int32_t>(start) + stride + 1;
    layout_.stride[l] = stride;
    layout_.scale_x[l] = static_cast<float>(m.cols) / static_cast<float>(images_[0].cols);
    layout_.scale_y[l] = static_cast<float>(m.rows) / static_cast<float>(images_[0].rows);
    start += static_cast<size_t>(stride) * (m.rows + 2);
  }
  layout_.pool = pool_.data();
  layout_.levels = static_cast<int>(images_.size());
  layout_.max_lod = static_cast<float>(layout_.levels - 1);
}

}  // namespace scale_drift_slam::sim
