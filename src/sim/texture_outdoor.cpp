// Outdoor materials: facades, paving, terrain (sim/texture_generator.h).

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "scale_drift_slam/sim/texture_generator.h"

namespace scale_drift_slam::sim::textures {
namespace {

/// Brick courses with mortar joints and a grey level per brick.
void drawBricks(cv::Mat& image, double texels_per_metre, cv::RNG& rng) {
  const double brick_w = 0.24 * texels_per_metre, brick_h = 0.075 * texels_per_metre;
  const double base = rng.uniform(90, 170);
  image.setTo(cv::Scalar(base + 45));  // mortar
  const int courses = static_cast<int>(image.rows / brick_h) + 1;
  for (int row = 0; row < courses; ++row) {
    const double offset = (row % 2) * brick_w / 2;
    for (double x = -offset; x < image.cols; x += brick_w) {
      const cv::Rect brick(static_cast<int>(x + 1), static_cast<int>(row * brick_h + 1),
                           static_cast<int>(brick_w - 2), static_cast<int>(brick_h - 2));
      cv::rectangle(image, brick, cv::Scalar(base + rng.gaussian(18)), cv::FILLED);
    }
  }
}

/// Large stone blocks of random widths.
void drawStones(cv::Mat& image, double texels_per_metre, cv::RNG& rng) {
  const double course_h = rng.uniform(0.35, 0.6) * texels_per_metre;
  const double base = rng.uniform(110, 190);
  image.setTo(cv::Scalar(base - 40));
  for (double y = 0; y < image.rows; y += course_h) {
    for (double x = -rng.uniform(0.0, 1.0) * texels_per_metre; x < image.cols;) {
      const double w = rng.uniform(0.5, 1.3) * texels_per_metre;
      cv::rectangle(image, cv::Rect(static_cast<int>(x + 2), static_cast<int>(y + 2),
                                    static_cast<int>(w - 4), static_cast<int>(course_h - 4)),
                    cv::Scalar(base + rng.gaussian(14)), cv::FILLED);
      x += w;
    }
  }
}

/// One window: frame, panes with reflections, curtains or blinds, a sill.
void drawWindow(cv::Mat& image, const cv::Rect& box, int style, cv::RNG& rng) {
  const int frame = std::max(2, box.width / 14);
  const cv::Rect inner(box.x + frame, box.y + frame, box.width - 2 * frame, box.height - 2 * frame);
  cv::rectangle(image, box, cv::Scalar(style % 2 ? 225 : 60), cv::FILLED);
  cv::Mat glass = fractalNoise(inner.size(), inner.width / 1.5, 3, 0.5, rng);
  glass.convertTo(image(inner), CV_8U, 35, rng.uniform(35, 85));
  // Reflection: a bright diagonal band, clipped to the glass.
  const int shift = rng.uniform(0, std::max(1, inner.width));
  const std::vector<cv::Point> band = {{shift, 0},
                                       {shift + inner.width / 4, 0},
                                       {shift - inner.width / 3, inner.height},
                                       {shift - inner.width / 2, inner.height}};
  cv::Mat glass_view = image(inner);
  cv::fillConvexPoly(glass_view, band, cv::Scalar(rng.uniform(100, 160)), cv::LINE_AA);
  const int content = rng.uniform(0, 5);
  if (content == 0) {  // blinds
    for (int y = inner.y; y < inner.y + inner.height * 2 / 3; y += std::max(2, box.height / 25)) {
      cv::line(image, {inner.x, y}, {inner.br().x - 1, y}, cv::Scalar(200), 1);
    }
  } else if (content == 1) {  // curtains
    const int cw = inner.width / 4;
    cv::rectangle(image, cv::Rect(inner.x, inner.y, cw, inner.height), cv::Scalar(rng.uniform(150, 240)), cv::FILLED);
    cv::rectangle(image, cv::Rect(inner.br().x - cw, inner.y, cw, inner.height), cv::Scalar(rng.uniform(150, 240)), cv::FILLED);
  } else if (content == 2) {  // a plant or an object on the sill
    cv::circle(image, {inner.x + rng.uniform(inner.width / 4, inner.width * 3 / 4), inner.br().y - inner.height / 6},
               inner.width / 6, cv::Scalar(rng.uniform(20, 90)), cv::FILLED, cv::LINE_AA);
  }
  // Mullions (2x2, 2x3, 1x2 panes).
  const int cols = 1 + style % 3, rows = 2 + (style / 3) % 2;
  const cv::Scalar mullion(style % 2 ? 225 : 60);
  for (int c = 1; c < cols; ++c) {
    const int x = inner.x + inner.width * c / cols;
    cv::line(image, {x, inner.y}, {x, inner.br().y}, mullion, std::max(1, frame / 2));
  }
  for (int r = 1; r < rows; ++r) {
    const int y = inner.y + inner.height * r / rows;
    cv::line(image, {inner.x, y}, {inner.br().x, y}, mullion, std::max(1, frame / 2));
  }
  cv::rectangle(image, cv::Rect(box.x - frame, box.br().y, box.width + 2 * frame, frame * 2),
                cv::Scalar(rng.uniform(170, 240)), cv::FILLED);
}

/// A wooden door with panels and a handle.
void drawDoor(cv::Mat& image, const cv::Rect& box, cv::RNG& rng) {
  cv::Mat wood = fractalNoise(box.size(), box.width / 6.0, 4, 0.55, rng);
  wood.convertTo(image(box & cv::Rect(0, 0, image.cols, image.rows)), CV_8U, 25, rng.uniform(50, 150));
  const int m = box.width / 8;
  for (int k = 0; k < 2; ++k) {
    const cv::Rect panel(box.x + m, box.y + m + k * box.height / 2, box.width - 2 * m, box.height / 2 - 2 * m);
    cv::rectangle(image, panel, cv::Scalar(rng.uniform(20, 90)), std::max(1, m / 3));
  }
  cv::circle(image, {box.x + box.width - 2 * m, box.y + box.height / 2}, std::max(2, m / 2),
             cv::Scalar(230), cv::FILLED, cv::LINE_AA);
}

}  // namespace

cv::Mat facade(double width_m, double height_m, double texels_per_metre, std::uint32_t seed) {
  cv::RNG rng(0x5eed0000ULL + seed);
  const double tpm = texels_per_metre;
  cv::Mat image(static_cast<int>(height_m * tpm), static_cast<int>(width_m * tpm), CV_8U);
  const int material = rng.uniform(0, 3);
  if (material == 0) {
    drawBricks(image, tpm, rng);
  } else if (material == 1) {
    drawStones(image, tpm, rng);
  } else {
    image.setTo(cv::Scalar(rng.uniform(150, 215)));  // plaster: weakly textured
  }
  // Storeys of windows above a ground floor; a plain band between storeys (weak texture).
  const double storey = rng.uniform(2.8, 3.4);
  const double spacing = rng.uniform(2.4, 3.4);
  const double win_w = rng.uniform(0.9, 1.4), win_h = rng.uniform(1.3, 1.9);
  const int style = rng.uniform(0, 6);
  const int columns = static_cast<int>(width_m / spacing);
  const double margin = (width_m - columns * spacing) / 2 + spacing / 2;
  for (double top = height_m - storey; top > 2.5; top -= storey) {
    const int band_y = static_cast<int>((height_m - top - storey) * tpm);
    cv::rectangle(image, cv::Rect(0, band_y, image.cols, static_cast<int>(0.25 * tpm)),
                  cv::Scalar(rng.uniform(170, 235)), cv::FILLED);
    for (int c = 0; c < columns; ++c) {
      if (rng.uniform(0, 9) == 0) continue;  // a missing window
      const double cx = margin + c * spacing;
      const cv::Rect box(static_cast<int>((cx - win_w / 2) * tpm),
                         static_cast<int>((height_m - top - storey + 0.8) * tpm),
                         static_cast<int>(win_w * tpm), static_cast<int>(win_h * tpm));
      drawWindow(image, box, style, rng);
    }
  }
  // Ground floor: doors, posters, a named sign, a shop window.
  const int ground_y = static_cast<int>((height_m - 2.6) * tpm);
  for (double x = rng.uniform(0.3, 1.5); x < width_m - 1.6;) {
    const int kind = rng.uniform(0, 4);
    const int px = static_cast<int>(x * tpm);
    if (kind == 0) {
      drawDoor(image, cv::Rect(px, ground_y + static_cast<int>(0.4 * tpm), static_cast<int>(1.1 * tpm),
                               static_cast<int>(2.15 * tpm)), rng);
      x += 1.1;
    } else if (kind == 1) {
      const cv::Size size(static_cast<int>(rng.uniform(0.6, 1.2) * tpm),
                          static_cast<int>(rng.uniform(0.8, 1.4) * tpm));
      poster(size, rng).copyTo(image(cv::Rect(px, ground_y + static_cast<int>(0.7 * tpm), size.width, size.height)));
      x += size.width / tpm;
    } else if (kind == 2) {
      drawWindow(image, cv::Rect(px, ground_y + static_cast<int>(0.5 * tpm),
                                 static_cast<int>(1.5 * tpm), static_cast<int>(1.6 * tpm)), 4, rng);
      x += 1.5;
    }
    x += rng.uniform(0.4, 1.8);
  }
  const cv::Rect sign(static_cast<int>(rng.uniform(0.1, 0.5) * image.cols), ground_y,
                      static_cast<int>(0.35 * image.cols), static_cast<int>(0.3 * tpm));
  cv::rectangle(image, sign & cv::Rect(0, 0, image.cols, image.rows), cv::Scalar(rng.uniform(20, 60)), cv::FILLED);
  drawTextInBox(image, randomWord(rng, 2, 4), sign, 235, cv::FONT_HERSHEY_TRIPLEX, std::max(1, sign.height / 12));
  // Drain pipes and climbing plants.
  for (int k = rng.uniform(1, 3); k > 0; --k) {
    const int x = rng.uniform(0, image.cols);
    cv::line(image, {x, 0}, {x, image.rows}, cv::Scalar(rng.uniform(30, 90)), std::max(2, static_cast<int>(0.08 * tpm)));
  }
  cv::Mat plant = fractalNoise(image.size(), 1.5 * tpm, 6, 0.6, rng);
  cv::Mat leaves = fractalNoise(image.size(), 0.1 * tpm, 3, 0.7, rng);
  cv::Mat plant_mask = plant > 0.45f;
  cv::Mat leaf_image;
  leaves.convertTo(leaf_image, CV_8U, 90, 60);
  leaf_image.copyTo(image, plant_mask);
  // Weathering: large-scale dirt plus fine grain.
  addNoise(image, 28, 3.0 * tpm, 4, rng);
  addNoise(image, 10, 0.05 * tpm, 2, rng);
  return image;
}

cv::Mat pavedGround(double width_m, double depth_m, double texels_per_metre, std::uint32_t seed) {
  cv::RNG rng(0x6a0d0000ULL + seed);
  const double tpm = texels_per_metre;
  cv::Mat image(static_cast<int>(depth_m * tpm), static_cast<int>(width_m * tpm), CV_8U);
  image.setTo(cv::Scalar(70));  // joints
  const double slab = rng.uniform(0.45, 0.65) * tpm;
  for (double y = 0; y < image.rows; y += slab) {
    const double offset = rng.uniform(0.0, slab);
    for (double x = -offset; x < image.cols; x += slab) {
      cv::rectangle(image, cv::Rect(static_cast<int>(x + 2), static_cast<int>(y + 2),
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
    drawTextInBox(image, randomWord(rng, 1, 2), box, 235, cv::FONT_HERSHEY_SIMPLEX, std::max(1, static_cast<int>(0.05 * tpm)));
  }
  addNoise(image, 25, 2.0 * tpm, 4, rng);
  addNoise(image, 14, 0.03 * tpm, 2, rng);
  return image;
}

cv::Mat terrain(int height, std::uint32_t seed) {
  cv::RNG rng(0x7e770000ULL + seed);
  const int width = 2 * height, wrap = height / 4;  // drawn wider, then blended across the seam
  cv::Mat wide(height, width + wrap, CV_8U);
  cv::Mat base = fractalNoise(wide.size(), height / 4.0, 7, 0.55, rng);
  base.convertTo(wide, CV_8U, 60, 120);
  // Fields with crop rows: rotated ellipses filled with stripes.
  for (int k = 0; k < 260; ++k) {
    const cv::Point c(rng.uniform(0, wide.cols), rng.uniform(0, height));
    const cv::Size2f axes(rng.uniform(height / 60, height / 15), rng.uniform(height / 60, height / 15));
    const double angle = rng.uniform(0.0, 180.0);
    const int reach = static_cast<int>(std::max(axes.width, axes.height) / 2) + 1;
    const cv::Rect roi = cv::Rect(c.x - reach, c.y - reach, 2 * reach, 2 * reach) &
                         cv::Rect(0, 0, wide.cols, wide.rows);
    if (roi.empty()) continue;
    cv::Mat mask(roi.size(), CV_8U, cv::Scalar(0));
    cv::ellipse(mask, cv::RotatedRect(cv::Point2f(c - roi.tl()), axes, static_cast<float>(angle)),
                cv::Scalar(255), cv::FILLED);
    const double level = rng.uniform(60, 210), stripe = rng.uniform(3.0, 8.0);
    const double dx = std::cos(angle * CV_PI / 180.0) / stripe, dy = std::sin(angle * CV_PI / 180.0) / stripe;
    for (int y = 0; y < roi.height; ++y) {
      for (int x = 0; x < roi.width; ++x) {
        if (!mask.at<uchar>(y, x)) continue;
        const int phase = static_cast<int>(std::floor(x * dx + y * dy));
        wide.at<uchar>(roi.y + y, roi.x + x) = cv::saturate_cast<uchar>(level + ((phase & 1) ? 22 : -22));
      }
    }
  }
  // Lakes (weakly textured), villages, roads.
  cv::Mat water = fractalNoise(wide.size(), height / 6.0, 5, 0.5, rng);
  wide.setTo(cv::Scalar(45), water > 0.5f);
  for (int k = 0; k < 90; ++k) {
    const cv::Point c(rng.uniform(0, wide.cols), rng.uniform(0, height));
    for (int b = rng.uniform(4, 14); b > 0; --b) {
      const cv::Rect house(c.x + rng.uniform(-height / 60, height / 60), c.y + rng.uniform(-height / 60, height / 60),
                           rng.uniform(3, height / 90 + 4), rng.uniform(3, height / 90 + 4));
      cv::rectangle(wide, house, cv::Scalar(rng.uniform(0, 2) ? 235 : 30), cv::FILLED);
    }
  }
  for (int k = 0; k < 40; ++k) {
    std::vector<cv::Point> road = {{rng.uniform(0, wide.cols), rng.uniform(0, height)}};
    for (int s = 0; s < 6; ++s) {
      road.push_back(road.back() + cv::Point(rng.uniform(-height / 8, height / 8), rng.uniform(-height / 8, height / 8)));
    }
    cv::polylines(wide, road, false, cv::Scalar(rng.uniform(0, 2) ? 200 : 25), std::max(1, height / 700 + 1), cv::LINE_AA);
  }
  addNoise(wide, 12, 6.0, 2, rng);
  // Blend the extra columns onto the start so that longitude 0 and 360 meet without a seam.
  cv::Mat result = wide(cv::Rect(0, 0, width, height)).clone();
  for (int x = 0; x < wrap; ++x) {
    const double w = static_cast<double>(x) / wrap;
    cv::addWeighted(wide.col(width + x), 1.0 - w, wide.col(x), w, 0.0, result.col(x));
  }
  return result;
}

}  // namespace scale_drift_slam::sim::textures
