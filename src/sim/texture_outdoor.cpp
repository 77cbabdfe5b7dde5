// Outdoor materials: paving and terrain (sim/texture_generator.h); facades are in
// texture_facade.cpp.

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "scale_drift_slam/sim/texture_generator.h"

namespace scale_drift_slam::sim::textures {
cv::Mat pavedGround(double width_m, double depth_m, double texels_per_metre, std::uint32_t seed) {
  cv::RNG rng(0x6a0d0000ULL + seed);
  const double tpm = texels_per_metre;
  cv::Mat image(static_cast<int>(depth_m * tpm), static_cast<int>(width_m * tpm), CV_8U);
  image.setTo(cv::Scalar(70));  // joints
  const double slab = rng.uniform(0.45, 0.65) * tpm;
  for (double y = 0; y < image.rows; y += slab) {
    const double offset = rng.uniform(0.0, slab);
    for (double x = -offset; x < image.cols; x += slab) {
      cv::rectangle(image,
                    cv::Rect(static_cast<int>(x + 2), static_cast<int>(y + 2),
                             static_cast<int>(slab - 3), static_cast<int>(slab - 3)),
                    cv::Scalar(rng.uniform(115, 175)), cv::FILLED);
    }
  }
  // Lawn and gravel patches, manhole covers, painted markings.
  cv::Mat patches = fractalNoise(image.size(), 6.0 * tpm, 4, 0.55, rng);
  cv::Mat grass = fractalNoise(image.size(), 0.06 * tpm, 3, 0.8, rng);
  cv::Mat grass8;
  grass.convertTo(grass8, CV_8U, 70, 85);
  grass8.copyTo(image, patches > 0.35f);
  for (int k = rng.uniform(3, 8); k > 0; --k) {
    const cv::Point c(rng.uniform(0, image.cols), rng.uniform(0, image.rows));
    cv::circle(image, c, static_cast<int>(0.35 * tpm), cv::Scalar(50), cv::FILLED, cv::LINE_AA);
    cv::circle(image, c, static_cast<int>(0.3 * tpm), cv::Scalar(95), static_cast<int>(0.03 * tpm));
  }
  for (int k = rng.uniform(2, 5); k > 0; --k) {
    const cv::Rect box(rng.uniform(0, image.cols * 3 / 4), rng.uniform(0, image.rows * 3 / 4),
                       static_cast<int>(2.0 * tpm), static_cast<int>(0.6 * tpm));
    drawTextInBox(image, randomWord(rng, 1, 2), box, 235, cv::FONT_HERSHEY_SIMPLEX,
                  std::max(1, static_cast<int>(0.05 * tpm)));
  }
  addNoise(image, 25, 2.0 * tpm, 4, rng);
  addNoise(image, 14, 0.03 * tpm, 2, rng);
  return image;
}

namespace {

/// Fractal noise that is periodic in x (drawn wider, the extra columns blended onto the start).
cv::Mat periodicNoise(cv::Size size, double period, int octaves, cv::RNG& rng) {
  const int wrap = std::max(2, size.width / 8);
  cv::Mat wide = fractalNoise(cv::Size(size.width + wrap, size.height), period, octaves, 0.6, rng);
  cv::Mat result = wide(cv::Rect(0, 0, size.width, size.height)).clone();
  for (int x = 0; x < wrap; ++x) {
    const double w = static_cast<double>(x) / wrap;
    cv::addWeighted(wide.col(size.width + x), 1.0 - w, wide.col(x), w, 0.0, result.col(x));
  }
  return result;
}

struct Field {
  int kind = 0;  ///< 0 crop rows, 1 meadow, 2 orchard, 3 forest, 4 water
  float level = 128, amplitude = 20, period = 6;
  float dx = 1, dy = 0;
};

float fieldValue(const Field& f, int x, int y, float fine) {
  switch (f.kind) {
    case 0:
      return f.level +
             ((static_cast<int>(std::floor((x * f.dx + y * f.dy) / f.period)) & 1) ? f.amplitude
                                                                                   : -f.amplitude) +
             6 * fine;
    case 1:
      return f.level + 14 * fine;
    case 2: {
      const int gx = static_cast<int>(x * f.dx + y * f.dy) % static_cast<int>(f.period * 2);
      const int gy = static_cast<int>(-x * f.dy + y * f.dx) % static_cast<int>(f.period * 2);
      return (std::abs(gx) < 3 && std::abs(gy) < 3) ? f.level - 70 : f.level + 8 * fine;
    }
    case 3:
      return f.level - 40 + 45 * fine;
    default:
      return 50 + 3 * fine;
  }
}

/// A patchwork of fields: a Voronoi partition with periodic seeds (copies shifted by +-width),
/// each cell a field of its own kind, with dark hedges along the borders.
cv::Mat fieldPatchwork(int width, int height, cv::RNG& rng) {
  const int margin = height / 8;
  const int fields = width * height / (110 * 110);
  cv::Mat seeds(height, width + 2 * margin, CV_8U, cv::Scalar(255));
  std::vector<cv::Point> centres;
  for (int k = 0; k < fields; ++k)
    centres.emplace_back(rng.uniform(0, width), rng.uniform(0, height));
  for (const cv::Point& c : centres) {
    for (int shift : {-width, 0, width}) {
      const int x = c.x + shift + margin;
      if (x >= 0 && x < seeds.cols) seeds.at<uchar>(c.y, x) = 0;
    }
  }
  cv::Mat distance, labels;
  cv::distanceTransform(seeds, distance, labels, cv::DIST_L2, cv::DIST_MASK_5,
                        cv::DIST_LABEL_PIXEL);
  std::vector<int> field_of_label(static_cast<size_t>(fields) * 3 + 2, 0);
  for (int k = 0; k < fields; ++k) {
    for (int shift : {-width, 0, width}) {
      const int x = centres[static_cast<size_t>(k)].x + shift + margin;
      if (x < 0 || x >= seeds.cols) continue;
      const int label = labels.at<int>(centres[static_cast<size_t>(k)].y, x);
      if (label >= 0 && static_cast<size_t>(label) < field_of_label.size())
        field_of_label[static_cast<size_t>(label)] = k;
    }
  }
  std::vector<Field> params(static_cast<size_t>(fields));
  for (Field& f : params) {
    const int r = rng.uniform(0, 20);
    f.kind = r < 10 ? 0 : r < 14 ? 1 : r < 16 ? 2 : r < 19 ? 3 : 4;
    f.level = static_cast<float>(rng.uniform(70, 200));
    f.amplitude = static_cast<float>(rng.uniform(10, 35));
    f.period = static_cast<float>(rng.uniform(3.0, 9.0));
    const double angle = rng.uniform(0.0, CV_PI);
    f.dx = static_cast<float>(std::cos(angle));
    f.dy = static_cast<float>(std::sin(angle));
  }
  const cv::Mat fine = periodicNoise(cv::Size(width, height), 6.0, 3, rng);
  cv::Mat image(height, width, CV_8U);
  for (int y = 0; y < height; ++y) {
    const int* label = labels.ptr<int>(y) + margin;
    const float* noise = fine.ptr<float>(y);
    uchar* out = image.ptr<uchar>(y);
    for (int x = 0; x < width; ++x) {
      const int id = field_of_label[static_cast<size_t>(
          std::min<int>(label[x], static_cast<int>(field_of_label.size()) - 1))];
      float v = fieldValue(params[static_cast<size_t>(id)], x, y, noise[x]);
      // Hedges and tracks along the field borders.
      const int right = label[x + 1 < width + margin ? x + 1 : x],
                below = y + 1 < height ? labels.ptr<int>(y + 1)[margin + x] : label[x];
      if (field_of_label[static_cast<size_t>(
              std::min<int>(right, static_cast<int>(field_of_label.size()) - 1))] != id ||
          field_of_label[static_cast<size_t>(
              std::min<int>(below, static_cast<int>(field_of_label.size()) - 1))] != id) {
        v = 35;
      }
      out[x] = cv::saturate_cast<uchar>(v);
    }
  }
  cv::erode(image, image, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2, 2)));
  return image;
}

/// Villages and roads, drawn three times (shifted by +-width) to wrap around in longitude.
void drawSettlements(cv::Mat& image, cv::RNG& rng) {
  const int width = image.cols, height = image.rows;
  for (int k = 0; k < width * height / 60000; ++k) {
    const cv::Point c(rng.uniform(0, width), rng.uniform(0, height));
    for (int b = rng.uniform(3, 12); b > 0; --b) {
      const cv::Rect house(c.x + rng.uniform(-60, 60), c.y + rng.uniform(-60, 60),
                           rng.uniform(8, 30), rng.uniform(8, 30));
      const cv::Scalar roof(rng.uniform(0, 2) ? rng.uniform(200, 250) : rng.uniform(20, 60));
      for (int shift : {-width, 0, width}) {
        cv::rectangle(image, house + cv::Point(shift, 0), roof, cv::FILLED);
        cv::line(image, house.tl() + cv::Point(shift, house.height / 2),
                 house.br() + cv::Point(shift, -house.height / 2), cv::Scalar(110), 1);
      }
    }
  }
  for (int k = 0; k < width * height / 200000; ++k) {
    std::vector<cv::Point> road = {{rng.uniform(0, width), rng.uniform(0, height)}};
    for (int s = 0; s < 8; ++s)
      road.push_back(road.back() + cv::Point(rng.uniform(-300, 300), rng.uniform(-300, 300)));
    const cv::Scalar colour(rng.uniform(0, 2) ? 215 : 25);
    for (int shift : {-width, 0, width}) {
      std::vector<cv::Point> shifted;
      for (const cv::Point& p : road)
        shifted.push_back(p + cv::Point(shift, 0));
      cv::polylines(image, shifted, false, colour, 5, cv::LINE_AA);
    }
  }
}

}  // namespace

cv::Mat terrain(int height, std::uint32_t seed) {
  cv::RNG rng(0x7e770000ULL + seed);
  cv::Mat image = fieldPatchwork(2 * height, height, rng);
  drawSettlements(image, rng);
  cv::Mat as_float;
  image.convertTo(as_float, CV_32F);
  as_float += 25.0 * periodicNoise(image.size(), height / 5.0, 5, rng);
  as_float.convertTo(image, CV_8U);
  return image;
}

}  // namespace scale_drift_slam::sim::textures
