// Building facades (sim/texture_generator.h).

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
      cv::rectangle(image,
                    cv::Rect(static_cast<int>(x + 2), static_cast<int>(y + 2),
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
    cv::rectangle(image, cv::Rect(inner.x, inner.y, cw, inner.height),
                  cv::Scalar(rng.uniform(150, 240)), cv::FILLED);
    cv::rectangle(image, cv::Rect(inner.br().x - cw, inner.y, cw, inner.height),
                  cv::Scalar(rng.uniform(150, 240)), cv::FILLED);
  } else if (content == 2) {  // a plant or an object on the sill
    cv::circle(image,
               {inner.x + rng.uniform(inner.width / 4, inner.width * 3 / 4),
                inner.br().y - inner.height / 6},
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
  wood.convertTo(image(box & cv::Rect(0, 0, image.cols, image.rows)), CV_8U, 25,
                 rng.uniform(50, 150));
  const int m = box.width / 8;
  for (int k = 0; k < 2; ++k) {
    const cv::Rect panel(box.x + m, box.y + m + k * box.height / 2, box.width - 2 * m,
                         box.height / 2 - 2 * m);
    cv::rectangle(image, panel, cv::Scalar(rng.uniform(20, 90)), std::max(1, m / 3));
  }
  cv::circle(image, {box.x + box.width - 2 * m, box.y + box.height / 2}, std::max(2, m / 2),
             cv::Scalar(230), cv::FILLED, cv::LINE_AA);
}

/// Rows of the facade texture run downwards from its top: y = (height - z) * texels_per_metre.
struct FacadeFrame {
  double height_m;
  double tpm;
  int row(double z) const { return static_cast<int>((height_m - z) * tpm); }
};

/// Storeys of windows above a 2.6 m ground floor; a plain band at each storey floor (weak
/// texture).
void drawStoreys(cv::Mat& image, const FacadeFrame& f, double width_m, cv::RNG& rng) {
  const double tpm = f.tpm, height_m = f.height_m;
  auto row_of = [&](double z) { return f.row(z); };
  const double storey = rng.uniform(2.8, 3.4), ground_floor = 2.6;
  const double spacing = rng.uniform(2.2, 3.2);
  const double win_w = rng.uniform(0.9, 1.4), win_h = rng.uniform(1.3, 1.8);
  const int style = rng.uniform(0, 6);
  const int columns = static_cast<int>(width_m / spacing);
  const double margin = (width_m - columns * spacing) / 2 + spacing / 2;
  for (double floor_z = ground_floor; floor_z + 2.2 < height_m; floor_z += storey) {
    cv::rectangle(image,
                  cv::Rect(0, row_of(floor_z + 0.25), image.cols, static_cast<int>(0.25 * tpm)),
                  cv::Scalar(rng.uniform(170, 235)), cv::FILLED);
    for (int c = 0; c < columns; ++c) {
      if (rng.uniform(0, 9) == 0) continue;  // a missing window
      const double cx = margin + c * spacing;
      const cv::Rect box(static_cast<int>((cx - win_w / 2) * tpm), row_of(floor_z + 0.8 + win_h),
                         static_cast<int>(win_w * tpm), static_cast<int>(win_h * tpm));
      if (box.y >= 0) drawWindow(image, box, style, rng);
    }
  }
}

/// One ground-floor item of the given kind at x (texels); returns its width in metres.
double drawGroundFloorItem(cv::Mat& image, const FacadeFrame& f, int kind, int px, cv::RNG& rng) {
  const double tpm = f.tpm;
  auto row_of = [&](double z) { return f.row(z); };
  if (kind == 0) {
    drawDoor(image,
             cv::Rect(px, row_of(2.15), static_cast<int>(1.1 * tpm), static_cast<int>(2.15 * tpm)),
             rng);
    return 1.1;
  } else if (kind == 1 || kind == 4) {
    const double w = rng.uniform(0.5, 1.1), h = rng.uniform(0.7, 1.3),
                 bottom = rng.uniform(0.6, 1.0);
    poster(cv::Size(static_cast<int>(w * tpm), static_cast<int>(h * tpm)), rng)
        .copyTo(image(cv::Rect(px, row_of(bottom + h), static_cast<int>(w * tpm),
                               static_cast<int>(h * tpm))));
    return w;
  } else if (kind == 2) {
    const double w = rng.uniform(1.4, 2.4);
    drawWindow(image,
               cv::Rect(px, row_of(2.2), static_cast<int>(w * tpm), static_cast<int>(1.7 * tpm)), 4,
               rng);
    return w;
  } else if (kind == 3) {  // notice board: cork with small notes
    const cv::Rect board(px, row_of(2.0), static_cast<int>(1.2 * tpm), static_cast<int>(0.9 * tpm));
    cv::Mat cork = fractalNoise(board.size(), 0.05 * tpm, 3, 0.7, rng);
    cork.convertTo(image(board), CV_8U, 40, 140);
    for (int k = rng.uniform(3, 7); k > 0; --k) {
      const cv::Size note(static_cast<int>(rng.uniform(0.15, 0.3) * tpm),
                          static_cast<int>(rng.uniform(0.18, 0.35) * tpm));
      const cv::Point at(board.x + rng.uniform(0, board.width - note.width),
                         board.y + rng.uniform(0, board.height - note.height));
      poster(note, rng).copyTo(image(cv::Rect(at, note)));
    }
    return 1.2;
  } else {  // ventilation grille: repetitive slats
    const cv::Rect grille(px, row_of(rng.uniform(0.6, 1.8)), static_cast<int>(0.8 * tpm),
                          static_cast<int>(0.5 * tpm));
    image(grille).setTo(cv::Scalar(rng.uniform(40, 90)));
    for (int y = grille.y; y < grille.br().y; y += std::max(3, static_cast<int>(0.04 * tpm))) {
      cv::line(image, {grille.x, y}, {grille.br().x - 1, y}, cv::Scalar(rng.uniform(150, 220)), 1);
    }
    return 0.8;
  }
}

/// The ground floor: a dense mix of doors, shop windows, posters, notice boards, grilles and
/// signs, with short plain gaps.
void drawGroundFloor(cv::Mat& image, const FacadeFrame& f, double width_m, cv::RNG& rng) {
  const double tpm = f.tpm;
  for (double x = rng.uniform(0.1, 0.6); x < width_m - 2.6;) {
    const int kind = rng.uniform(0, 6);
    x += drawGroundFloorItem(image, f, kind, static_cast<int>(x * tpm), rng) +
         rng.uniform(0.15, 0.9);
  }
  const int ground_y = f.row(2.6);
  for (int k = rng.uniform(1, 3); k > 0; --k) {
    const cv::Rect sign(rng.uniform(0, image.cols - static_cast<int>(3.5 * tpm)),
                        ground_y - static_cast<int>(0.1 * tpm),
                        static_cast<int>(rng.uniform(1.5, 3.5) * tpm), static_cast<int>(0.3 * tpm));
    cv::rectangle(image, sign, cv::Scalar(rng.uniform(20, 60)), cv::FILLED);
    drawTextInBox(image, randomWord(rng, 2, 3), sign, 235, cv::FONT_HERSHEY_TRIPLEX,
                  std::max(1, sign.height / 12));
  }
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
  const FacadeFrame frame{height_m, tpm};
  drawStoreys(image, frame, width_m, rng);
  drawGroundFloor(image, frame, width_m, rng);
  auto row_of = [&](double z) { return frame.row(z); };
  // Drain pipes.
  for (int k = rng.uniform(1, 3); k > 0; --k) {
    const int x = rng.uniform(0, image.cols);
    cv::line(image, {x, 0}, {x, image.rows}, cv::Scalar(rng.uniform(30, 90)),
             std::max(2, static_cast<int>(0.08 * tpm)));
  }
  // Shrubs along the foot of the facade (below 1.4 m).
  const cv::Rect foot(0, row_of(1.4), image.cols, image.rows - row_of(1.4));
  cv::Mat plant = fractalNoise(foot.size(), 1.2 * tpm, 5, 0.6, rng);
  for (int y = 0; y < foot.height; ++y)
    plant.row(y) += 0.6f * (static_cast<float>(y) / foot.height - 0.6f);
  cv::Mat leaves = fractalNoise(foot.size(), 0.08 * tpm, 3, 0.7, rng);
  cv::Mat leaf_image;
  leaves.convertTo(leaf_image, CV_8U, 90, 70);
  leaf_image.copyTo(image(foot), plant > 0.35f);
  // Weathering: large-scale dirt plus fine grain.
  addNoise(image, 28, 3.0 * tpm, 4, rng);
  addNoise(image, 10, 0.05 * tpm, 2, rng);
  return image;
}

}  // namespace scale_drift_slam::sim::textures
