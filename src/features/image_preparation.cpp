#include "scale_drift_slam/features/image_preparation.h"

#include "scale_drift_slam/features/feature_detection.h"

#include <algorithm>
#include <stdexcept>

#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

namespace scale_drift_slam::features {

PixelEncoding parsePixelEncoding(const std::string& name) {
  if (name == "mono8" || name == "8UC1") return PixelEncoding::kMono8;
  if (name == "mono16" || name == "16UC1") return PixelEncoding::kMono16;
  if (name == "bgr8" || name == "8UC3") return PixelEncoding::kBgr8;
  if (name == "rgb8") return PixelEncoding::kRgb8;
  if (name == "bgra8" || name == "8UC4") return PixelEncoding::kBgra8;
  if (name == "rgba8") return PixelEncoding::kRgba8;
  throw std::invalid_argument("unsupported image encoding '" + name +
                              "' (accepted: mono8, mono16, bgr8, rgb8, bgra8, rgba8)");
}

std::string pixelEncodingName(PixelEncoding encoding) {
  switch (encoding) {
    case PixelEncoding::kMono8:
      return "mono8";
    case PixelEncoding::kMono16:
      return "mono16";
    case PixelEncoding::kBgr8:
      return "bgr8";
    case PixelEncoding::kRgb8:
      return "rgb8";
    case PixelEncoding::kBgra8:
      return "bgra8";
    case PixelEncoding::kRgba8:
      return "rgba8";
  }
  return "unknown";
}

PixelEncoding encodingOfMat(const cv::Mat& image) {
  switch (image.type()) {
    case CV_8UC1:
      return PixelEncoding::kMono8;
    case CV_16UC1:
      return PixelEncoding::kMono16;
    case CV_8UC3:
      return PixelEncoding::kBgr8;
    case CV_8UC4:
      return PixelEncoding::kBgra8;
    default:
      throw std::invalid_argument("unsupported OpenCV image type " + std::to_string(image.type()) +
                                  " (8-bit grey/BGR/BGRA or 16-bit grey expected)");
  }
}

namespace {

int expectedType(PixelEncoding encoding) {
  switch (encoding) {
    case PixelEncoding::kMono8:
      return CV_8UC1;
    case PixelEncoding::kMono16:
      return CV_16UC1;
    case PixelEncoding::kBgr8:
    case PixelEncoding::kRgb8:
      return CV_8UC3;
    case PixelEncoding::kBgra8:
    case PixelEncoding::kRgba8:
      return CV_8UC4;
  }
  return -1;
}

}  // namespace

int significantBits(const cv::Mat& mono16) {
  if (mono16.type() != CV_16UC1)
    throw std::invalid_argument("significantBits needs a 16-bit image");
  double largest = 0.0;
  if (!mono16.empty()) cv::minMaxLoc(mono16, nullptr, &largest);
  int bits = 8;
  while (bits < 16 && largest >= static_cast<double>(1 << bits))
    ++bits;
  return bits;
}

cv::Mat toGrey(const cv::Mat& image, PixelEncoding encoding, int mono16_bits) {
  if (image.empty()) throw std::invalid_argument("empty image");
  if (mono16_bits < 8 || mono16_bits > 16) {
    throw std::invalid_argument("16-bit images hold 8 to 16 bits, not " +
                                std::to_string(mono16_bits));
  }
  if (image.type() != expectedType(encoding)) {
    throw std::invalid_argument("image announced as " + pixelEncodingName(encoding) + " has " +
                                std::to_string(image.channels()) + " channel(s) of " +
                                std::to_string(image.elemSize1() * 8) + " bits");
  }
  cv::Mat grey;
  switch (encoding) {
    case PixelEncoding::kMono8:
      grey = image.clone();
      break;
    case PixelEncoding::kMono16:
      image.convertTo(grey, CV_8U, 1.0 / (1 << (mono16_bits - 8)));
      break;
    case PixelEncoding::kBgr8:
      cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
      break;
    case PixelEncoding::kRgb8:
      cv::cvtColor(image, grey, cv::COLOR_RGB2GRAY);
      break;
    case PixelEncoding::kBgra8:
      cv::cvtColor(image, grey, cv::COLOR_BGRA2GRAY);
      break;
    case PixelEncoding::kRgba8:
      cv::cvtColor(image, grey, cv::COLOR_RGBA2GRAY);
      break;
  }
  return grey;
}

cv::Mat normalisePhotometry(const cv::Mat& grey, int radius) {
  if (grey.empty() || grey.type() != CV_8UC1) {
    throw std::invalid_argument("photometric normalisation needs a non-empty 8-bit grey image");
  }
  if (radius < 1) throw std::invalid_argument("photometric normalisation needs a radius >= 1");
  // In 8 and 16 bits (the float version cost 4 ms per 640x480 frame): the local contrast is
  // the box mean of the absolute difference from the box mean, at least kMinLocalContrast.
  constexpr int kMinLocalContrast = 6;  // grey levels: flat areas and their noise stay flat
  const cv::Size box(2 * radius + 1, 2 * radius + 1);
  cv::Mat mean, deviation, contrast, difference, contrast16, normalised, out;
  cv::blur(grey, mean, box, cv::Point(-1, -1), cv::BORDER_REFLECT_101);
  cv::absdiff(grey, mean, deviation);
  cv::blur(deviation, contrast, box, cv::Point(-1, -1), cv::BORDER_REFLECT_101);
  cv::max(contrast, kMinLocalContrast, contrast);
  cv::subtract(grey, mean, difference, cv::noArray(), CV_16S);
  contrast.convertTo(contrast16, CV_16S);
  cv::divide(difference, contrast16, normalised, 26.0, CV_16S);
  normalised.convertTo(out, CV_8U, 1.0, 128.0);
  return out;
}

namespace {

/// `image` inside a buffer with `padding` pixels more on each side, filled by `border`.
cv::Mat padded(const cv::Mat& image, int padding, int border) {
  cv::Mat buffer;
  cv::copyMakeBorder(image, buffer, padding, padding, padding, padding, border);
  return buffer(cv::Rect(padding, padding, image.cols, image.rows));
}

/// The Scharr derivatives d/dx, d/dy of a grey image in one CV_16SC2 image (the layout of the
/// gradients cv::buildOpticalFlowPyramid makes).
cv::Mat scharrGradient(const cv::Mat& grey) {
  cv::Mat dx, dy, gradient;
  cv::Scharr(grey, dx, CV_16S, 1, 0);
  cv::Scharr(grey, dy, CV_16S, 0, 1);
  cv::merge(std::vector<cv::Mat>{dx, dy}, gradient);
  return gradient;
}

}  // namespace

std::vector<cv::Mat> ImagePyramid::lucasKanadePyramid(int num_levels) const {
  const std::vector<cv::Mat>& flow = flowLevels();
  const int n = std::min(num_levels, static_cast<int>(flow.size()));
  const bool with_gradients = flow_gradients.size() == flow.size();
  std::vector<cv::Mat> pyramid;
  for (int level = 0; level < n; ++level) {
    pyramid.push_back(flow[level]);
    if (with_gradients) pyramid.push_back(flow_gradients[level]);
  }
  return pyramid;
}

std::vector<cv::Mat> ImagePyramid::baseLevelForLucasKanade(int window) const {
  cv::Size whole;
  cv::Point offset;
  base().locateROI(whole, offset);
  if (offset.x < window || offset.y < window || offset.x + base().cols + window > whole.width ||
      offset.y + base().rows + window > whole.height) {
    return {};
  }
  std::vector<cv::Mat> level{base()};
  if (flow_levels.empty() && !flow_gradients.empty()) level.push_back(flow_gradients.front());
  return level;
}

std::shared_ptr<FastCornerCache> ImagePyramid::corners() const {
  return fast_corners ? fast_corners : std::make_shared<FastCornerCache>(base());
}

ImagePyramid buildPyramid(const cv::Mat& grey, int num_levels, int padding,
                          int photometric_radius) {
  if (grey.empty() || grey.type() != CV_8UC1) {
    throw std::invalid_argument("image pyramid needs a non-empty 8-bit grey image");
  }
  if (num_levels < 1) throw std::invalid_argument("image pyramid needs at least one level");
  if (padding < 1) throw std::invalid_argument("image pyramid needs a padding of at least 1");
  int max_level = 0;
  for (int w = grey.cols, h = grey.rows; max_level + 1 < num_levels && w >= 32 && h >= 32;
       w /= 2, h /= 2) {
    ++max_level;
  }
  ImagePyramid pyramid;
  // cv::buildOpticalFlowPyramid halves with cv::pyrDown and pads every level by `padding`
  // reflected pixels, the layout cv::calcOpticalFlowPyrLK reuses without rebuilding it. With
  // the photometric normalisation the flow does not look at these levels: no gradients then.
  const bool gradients_of_levels = photometric_radius <= 0;
  std::vector<cv::Mat> built;
  cv::buildOpticalFlowPyramid(grey, built, cv::Size(padding, padding), max_level,
                              gradients_of_levels, cv::BORDER_REFLECT_101, cv::BORDER_CONSTANT,
                              false);
  const std::size_t step = gradients_of_levels ? 2 : 1;
  for (std::size_t i = 0; i < built.size(); i += step) {
    pyramid.levels.push_back(built[i]);
    if (gradients_of_levels) pyramid.flow_gradients.push_back(built[i + 1]);
  }
  pyramid.fast_corners = std::make_shared<FastCornerCache>(pyramid.base());
  if (photometric_radius > 0) {
    // Each level on its own: the coarse levels keep the structure that Lucas-Kanade needs for
    // large motions (a high-passed image, halved, would be flat there).
    for (const cv::Mat& level : pyramid.levels) {
      const cv::Mat normalised = normalisePhotometry(level, photometric_radius);
      pyramid.flow_levels.push_back(padded(normalised, padding, cv::BORDER_REFLECT_101));
      pyramid.flow_gradients.push_back(
          padded(scharrGradient(normalised), padding, cv::BORDER_CONSTANT));
    }
  }
  return pyramid;
}

double stretchContrast(cv::Mat* grey, double target_range, double max_gain) {
  if (grey == nullptr || grey->empty() || grey->type() != CV_8UC1) {
    throw std::invalid_argument("contrast stretch needs a non-empty 8-bit grey image");
  }
  if (!(target_range > 0.0 && target_range <= 255.0) || !(max_gain >= 1.0)) {
    throw std::invalid_argument("contrast stretch needs target_range in (0, 255], max_gain >= 1");
  }
  // The histogram of every second pixel of every second row (a quarter of the work; every frame
  // pays it): percentiles of 10 800 samples at 240x180, 113 000 at KITTI's size.
  int histogram[256] = {0};
  int samples = 0;
  for (int r = 0; r < grey->rows; r += 2) {
    const unsigned char* row = grey->ptr<unsigned char>(r);
    for (int c = 0; c < grey->cols; c += 2) {
      ++histogram[row[c]];
      ++samples;
    }
  }
  // The 1st and 99th percentiles: a few hot or dead pixels do not count as contrast.
  const double total = static_cast<double>(samples);
  double below = 0.0;
  int low = 0, high = 255;
  for (int v = 0; v < 256; ++v) {
    below += histogram[v];
    if (below <= 0.01 * total) low = v + 1;
    if (below < 0.99 * total) high = v + 1;
  }
  const double range = std::max(0, high - low);
  if (range <= 0.0 || range >= target_range) return 1.0;
  const double gain = std::min(max_gain, target_range / range);
  if (gain <= 1.0) return 1.0;
  // Scaled about the range's centre, then moved just enough to keep the scaled range inside
  // 0-255. Not moved to mid-grey: a frame whose range hovers about the target (a textureless
  // wall in and out of view, motion blur) would be shifted by tens of grey levels on and off,
  // and the optical flow, which assumes a point keeps its grey level, fails on those frames.
  // This way the map tends to the identity as the range nears the target.
  const double centre = 0.5 * (low + high);
  const double scaled_low = centre + gain * (low - centre);
  const double scaled_high = centre + gain * (high - centre);
  const double shift = std::max(0.0, -scaled_low) - std::max(0.0, scaled_high - 255.0);
  grey->convertTo(*grey, CV_8U, gain, (1.0 - gain) * centre + shift);
  return gain;
}

std::string frameProblem(const cv::Mat& grey, int expected_width, int expected_height,
                         double min_contrast) {
  if (grey.empty()) return "empty image";
  if (grey.cols != expected_width || grey.rows != expected_height) {
    return "image is " + std::to_string(grey.cols) + "x" + std::to_string(grey.rows) +
           " but the calibration is " + std::to_string(expected_width) + "x" +
           std::to_string(expected_height);
  }
  cv::Scalar mean, stddev;
  cv::meanStdDev(grey, mean, stddev);
  if (stddev[0] < min_contrast) {
    return "image has no texture (grey-level standard deviation " + std::to_string(stddev[0]) + ")";
  }
  return "";
}

}  // namespace scale_drift_slam::features
