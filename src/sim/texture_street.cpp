// Street materials for the driving scenes (sim/texture_generator.h): asphalt with lane markings,
// kerb stones, parked cars and street furniture. Facades are in texture_facade.cpp, paving in
// texture_outdoor.cpp.

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "scale_drift_slam/sim/texture_generator.h"

namespace scale_drift_slam::sim::textures {
namespace {

/// Worn asphalt: grain at several scales, aggregate specks, repair patches, cracks, manholes.
void drawAsphalt(cv::Mat& image, double tpm, cv::RNG& rng) {
  image.setTo(cv::Scalar(rng.uniform(78, 100)));
  addNoise(image, 16, 4.0 * tpm, 4, rng);
  // Repairs: darker or lighter rectangles with sharp edges (strong corners, like real roads).
  const double area = image.total() / (tpm * tpm);
  for (int k = static_cast<int>(area / 120.0) + rng.uniform(1, 4); k > 0; --k) {
    const cv::Size size(static_cast<int>(rng.uniform(0.5, 3.0) * tpm),
                        static_cast<int>(rng.uniform(0.4, 2.0) * tpm));
    const cv::Rect box(rng.uniform(0, std::max(1, image.cols - size.width)),
                       rng.uniform(0, std::max(1, image.rows - size.height)), size.width,
                       size.height);
    cv::rectangle(image, box & cv::Rect(0, 0, image.cols, image.rows),
                  cv::Scalar(rng.uniform(55, 120)), cv::FILLED);
  }
  for (int k = static_cast<int>(area / 60.0) + 1; k > 0; --k) {  // cracks
    cv::Point p(rng.uniform(0, image.cols), rng.uniform(0, image.rows));
    for (int segment = rng.uniform(3, 9); segment > 0; --segment) {
      const cv::Point q = p + cv::Point(rng.uniform(-20, 21), rng.uniform(-20, 21)) *
                                  std::max(1.0, 0.15 * tpm / 20.0);
      cv::line(image, p, q, cv::Scalar(rng.uniform(30, 55)), 1, cv::LINE_AA);
      p = q;
    }
  }
  for (int k = static_cast<int>(area / 15.0); k > 0; --k) {  // aggregate and stains
    const cv::Point c(rng.uniform(0, image.cols), rng.uniform(0, image.rows));
    const int radius = std::max(1, static_cast<int>(rng.uniform(0.02, 0.12) * tpm));
    cv::circle(image, c, radius, cv::Scalar(rng.uniform(40, 150)), cv::FILLED);
  }
  for (int k = static_cast<int>(area / 300.0) + rng.uniform(0, 2); k > 0; --k) {  // manholes
    const cv::Point c(rng.uniform(0, image.cols), rng.uniform(0, image.rows));
    cv::circle(image, c, static_cast<int>(0.32 * tpm), cv::Scalar(45), cv::FILLED, cv::LINE_AA);
    cv::circle(image, c, static_cast<int>(0.26 * tpm), cv::Scalar(110),
               std::max(1, static_cast<int>(0.03 * tpm)));
  }
}

/// Painted marking (white, slightly worn) over the rectangle [x0, x1] x [y0, y1] in metres.
void paint(cv::Mat& image, double tpm, double x0, double y0, double x1, double y1, cv::RNG& rng) {
  const cv::Rect box(
      cv::Point(static_cast<int>(x0 * tpm), static_cast<int>(y0 * tpm)),
      cv::Point(static_cast<int>(std::ceil(x1 * tpm)), static_cast<int>(std::ceil(y1 * tpm))));
  cv::rectangle(image, box & cv::Rect(0, 0, image.cols, image.rows),
                cv::Scalar(rng.uniform(190, 235)), cv::FILLED);
}

/// A zebra crossing (bars along the road) from x0 to x0 + 3 m, a stop line before it.
void drawCrossing(cv::Mat& image, double tpm, double x0, double width_m, bool at_end,
                  cv::RNG& rng) {
  for (double y = 0.6; y + 0.5 < width_m - 0.4; y += 1.0)
    paint(image, tpm, x0, y, x0 + 3.0, y + 0.5, rng);
  // Traffic towards this end stops before the crossing: +x traffic drives at y > width / 2.
  const double stop_x = at_end ? x0 - 1.3 : x0 + 4.0;
  const double y0 = at_end ? width_m / 2 : 2.0, y1 = at_end ? width_m - 2.0 : width_m / 2;
  paint(image, tpm, stop_x, y0, stop_x + 0.3, y1, rng);
}

}  // namespace

cv::Mat road(double length_m, double width_m, double texels_per_metre, std::uint32_t seed,
             bool crossing_at_start, bool crossing_at_end) {
  cv::RNG rng(0x60ad0000ULL + seed);
  const double tpm = texels_per_metre;
  cv::Mat image(static_cast<int>(width_m * tpm), static_cast<int>(length_m * tpm), CV_8U);
  drawAsphalt(image, tpm, rng);
  const double first = crossing_at_start ? 6.0 : 0.0;
  const double last = length_m - (crossing_at_end ? 6.0 : 0.0);
  // Centre line: 3 m dashes, 5 m gaps; lines 2 m from each edge bound the parking strips, with
  // a tick at every bay.
  for (double x = first + rng.uniform(0.0, 8.0); x + 3.0 < last; x += 8.0)
    paint(image, tpm, x, width_m / 2 - 0.06, x + 3.0, width_m / 2 + 0.06, rng);
  for (const double y : {2.0, width_m - 2.0}) {
    paint(image, tpm, first, y - 0.06, last, y + 0.06, rng);
    for (double x = first + rng.uniform(2.0, 6.0); x < last; x += rng.uniform(5.2, 6.0)) {
      const double y0 = y < width_m / 2 ? y - 0.5 : y, y1 = y < width_m / 2 ? y : y + 0.5;
      paint(image, tpm, x, y0, x + 0.1, y1, rng);
    }
  }
  if (crossing_at_start) drawCrossing(image, tpm, 1.0, width_m, false, rng);
  if (crossing_at_end) drawCrossing(image, tpm, length_m - 4.0, width_m, true, rng);
  // Now and then an arrow in a lane.
  for (double x = first + rng.uniform(15.0, 40.0); x + 6 < last; x += rng.uniform(30.0, 70.0)) {
    const double y = rng.uniform(0, 2) ? width_m * 0.68 : width_m * 0.32;
    const double dir = y > width_m / 2 ? 1.0 : -1.0;
    paint(image, tpm, x, y - 0.08, x + 3.0, y + 0.08, rng);
    const double tip = dir > 0 ? x + 4.0 : x - 1.0, base = dir > 0 ? x + 3.0 : x;
    const std::vector<cv::Point> head = {
        cv::Point(static_cast<int>(tip * tpm), static_cast<int>(y * tpm)),
        cv::Point(static_cast<int>(base * tpm), static_cast<int>((y - 0.35) * tpm)),
        cv::Point(static_cast<int>(base * tpm), static_cast<int>((y + 0.35) * tpm))};
    cv::fillConvexPoly(image, head, cv::Scalar(215), cv::LINE_AA);
  }
  addNoise(image, 10, 1.0 * tpm, 3, rng);  // wear over paint and asphalt alike
  return image;
}

cv::Mat asphalt(double width_m, double depth_m, double texels_per_metre, std::uint32_t seed) {
  cv::RNG rng(0xa5fa0000ULL + seed);
  cv::Mat image(static_cast<int>(depth_m * texels_per_metre),
                static_cast<int>(width_m * texels_per_metre), CV_8U);
  drawAsphalt(image, texels_per_metre, rng);
  addNoise(image, 10, 1.0 * texels_per_metre, 3, rng);
  return image;
}

cv::Mat kerbStones(double length_m, double height_m, double texels_per_metre, std::uint32_t seed) {
  cv::RNG rng(0x6e4b0000ULL + seed);
  const double tpm = texels_per_metre;
  cv::Mat image(std::max(2, static_cast<int>(height_m * tpm)), static_cast<int>(length_m * tpm),
                CV_8U);
  image.setTo(cv::Scalar(60));  // joints
  for (double x = 0; x < image.cols; x += tpm) {
    cv::rectangle(image,
                  cv::Rect(static_cast<int>(x) + 1, 0, static_cast<int>(tpm) - 1, image.rows),
                  cv::Scalar(rng.uniform(150, 200)), cv::FILLED);
  }
  addNoise(image, 18, 0.5 * tpm, 3, rng);
  return image;
}

cv::Mat carBody(double length_m, double height_m, double texels_per_metre, std::uint32_t seed) {
  cv::RNG rng(0xca400000ULL + seed);
  const double tpm = texels_per_metre;
  cv::Mat image(static_cast<int>(height_m * tpm), static_cast<int>(length_m * tpm), CV_8U);
  const int paint_grey = rng.uniform(0, 3) == 0 ? rng.uniform(25, 60) : rng.uniform(90, 220);
  image.setTo(cv::Scalar(paint_grey));
  auto px = [&](double metres) { return static_cast<int>(metres * tpm); };
  // Windows: the upper third, dark glass with a reflection band, pillars between.
  const cv::Rect glass(px(0.12 * length_m), px(0.05 * height_m), px(0.76 * length_m),
                       px(0.33 * height_m));
  cv::Mat noise = fractalNoise(glass.size(), glass.width / 2.0, 3, 0.5, rng);
  noise.convertTo(image(glass), CV_8U, 30, rng.uniform(30, 70));
  for (int k = 1; k < 3; ++k) {
    const int x = glass.x + glass.width * k / 3;
    cv::line(image, {x, glass.y}, {x, glass.br().y}, cv::Scalar(paint_grey / 2 + 20), px(0.08));
  }
  // Door seams, handles, a bumper line, wheels with rims.
  for (int k = 1; k < 3; ++k) {
    const int x = glass.x + glass.width * k / 3;
    cv::line(image, {x, glass.br().y}, {x, px(0.85 * height_m)}, cv::Scalar(paint_grey / 3), 1);
    cv::rectangle(image, cv::Rect(x - px(0.25), px(0.5 * height_m), px(0.15), px(0.04)),
                  cv::Scalar(230 - paint_grey / 2), cv::FILLED);
  }
  cv::line(image, {0, px(0.7 * height_m)}, {image.cols, px(0.7 * height_m)}, cv::Scalar(40),
           std::max(1, px(0.04)));
  for (const double x : {0.18 * length_m, 0.82 * length_m}) {
    const cv::Point c(px(x), image.rows - px(0.32));
    cv::circle(image, c, px(0.32), cv::Scalar(20), cv::FILLED, cv::LINE_AA);
    cv::circle(image, c, px(0.18), cv::Scalar(rng.uniform(140, 210)), cv::FILLED, cv::LINE_AA);
  }
  addNoise(image, 8, 0.6 * tpm, 3, rng);
  return image;
}

cv::Mat streetMaterial(const std::string& kind, double width_m, double height_m,
                       double texels_per_metre, std::uint32_t seed) {
  cv::RNG rng(0x57e70000ULL + seed);
  const double tpm = texels_per_metre;
  cv::Mat image(std::max(2, static_cast<int>(height_m * tpm)),
                std::max(2, static_cast<int>(width_m * tpm)), CV_8U);
  if (kind == "foliage") {  // leaves: strong fine texture, darker clumps
    cv::Mat clumps = fractalNoise(image.size(), 0.8 * tpm, 3, 0.6, rng);
    cv::Mat leaves = fractalNoise(image.size(), 0.12 * tpm, 3, 0.8, rng);
    cv::Mat sum = 0.5f * clumps + leaves;
    sum.convertTo(image, CV_8U, 70, 95);
  } else if (kind == "bark") {
    image.setTo(cv::Scalar(rng.uniform(50, 80)));
    for (int x = 0; x < image.cols; x += std::max(2, static_cast<int>(0.05 * tpm)))
      cv::line(image, {x, 0}, {x, image.rows}, cv::Scalar(rng.uniform(25, 110)), 1);
    addNoise(image, 20, 0.3 * tpm, 3, rng);
  } else if (kind == "metal") {  // a painted pole: bands, stickers
    image.setTo(cv::Scalar(rng.uniform(60, 160)));
    for (int k = rng.uniform(1, 4); k > 0; --k) {
      const int y = rng.uniform(0, image.rows);
      cv::rectangle(image, cv::Rect(0, y, image.cols, std::max(2, static_cast<int>(0.2 * tpm))),
                    cv::Scalar(rng.uniform(20, 240)), cv::FILLED);
    }
    addNoise(image, 12, 0.5 * tpm, 3, rng);
  } else {
    throw std::invalid_argument("unknown street material '" + kind + "'");
  }
  return image;
}

}  // namespace scale_drift_slam::sim::textures
