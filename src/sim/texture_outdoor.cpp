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
  // Storeys of windows above a 2.6 m ground floor; a plain band at each storey floor (weak
  // texture). Rows of the texture run downwards from the top of the facade: y = height - z.
  const double storey = rng.uniform(2.8, 3.4), ground_floor = 2.6;
  const double spacing = rng.uniform(2.2, 3.2);
  const double win_w = rng.uniform(0.9, 1.4), win_h = rng.uniform(1.3, 1.8);
  const int style = rng.uniform(0, 6);
  const int columns = static_cast<int>(width_m / spacing);
  const double margin = (width_m - columns * spacing) / 2 + spacing / 2;
  auto row_of = [&](double z) { return static_cast<int>((height_m - z) * tpm); };
  for (double floor_z = ground_floor; floor_z + 2.2 < height_m; floor_z += storey) {
    cv::rectangle(image, cv::Rect(0, row_of(floor_z + 0.25), image.cols, static_cast<int>(0.25 * tpm)),
                  cv::Scalar(rng.uniform(170, 235)), cv::FILLED);
    for (int c = 0; c < columns; ++c) {
      if (rng.uniform(0, 9) == 0) continue;  // a missing window
      const double cx = margin + c * spacing;
      const cv::Rect box(static_cast<int>((cx - win_w / 2) * tpm), row_of(floor_z + 0.8 + win_h),
                         static_cast<int>(win_w * tpm), static_cast<int>(win_h * tpm));
      if (box.y >= 0) drawWindow(image, box, style, rng);
    }
  }
  // Ground floor: a dense mix of doors, shop windows, posters, notice boards, grilles and signs,
  // with short plain gaps.
  const int ground_y = row_of(ground_floor);
  for (double x = rng.uniform(0.1, 0.6); x < width_m - 2.6;) {
    const int kind = rng.uniform(0, 6);
    const int px = static_cast<int>(x * tpm);
    double used = 0.0;
    if (kind == 0) {
      drawDoor(image, cv::Rect(px, row_of(2.15), static_cast<int>(1.1 * tpm), static_cast<int>(2.15 * tpm)), rng);
      used = 1.1;
    } else if (kind == 1 || kind == 4) {
      const double w = rng.uniform(0.5, 1.1), h = rng.uniform(0.7, 1.3), bottom = rng.uniform(0.6, 1.0);
      poster(cv::Size(static_cast<int>(w * tpm), static_cast<int>(h * tpm)), rng)
          .copyTo(image(cv::Rect(px, row_of(bottom + h), static_cast<int>(w * tpm), static_cast<int>(h * tpm))));
      used = w;
    } else if (kind == 2) {
      const double w = rng.uniform(1.4, 2.4);
      drawWindow(image, cv::Rect(px, row_of(2.2), static_cast<int>(w * tpm), static_cast<int>(1.7 * tpm)), 4, rng);
      used = w;
    } else if (kind == 3) {  // notice board: cork with small notes
      const cv::Rect board(px, row_of(2.0), static_cast<int>(1.2 * tpm), static_cast<int>(0.9 * tpm));
      cv::Mat cork = fractalNoise(board.size(), 0.05 * tpm, 3, 0.7, rng);
      cork.convertTo(image(board), CV_8U, 40, 140);
      for (int k = rng.uniform(3, 7); k > 0; --k) {
        const cv::Size note(static_cast<int>(rng.uniform(0.15, 0.3) * tpm), static_cast<int>(rng.uniform(0.18, 0.35) * tpm));
        const cv::Point at(board.x + rng.uniform(0, board.width - note.width), board.y + rng.uniform(0, board.height - note.height));
        poster(note, rng).copyTo(image(cv::Rect(at, note)));
      }
      used = 1.2;
    } else {  // ventilation grille: repetitive slats
      const cv::Rect grille(px, row_of(rng.uniform(0.6, 1.8)), static_cast<int>(0.8 * tpm), static_cast<int>(0.5 * tpm));
      image(grille).setTo(cv::Scalar(rng.uniform(40, 90)));
      for (int y = grille.y; y < grille.br().y; y += std::max(3, static_cast<int>(0.04 * tpm))) {
        cv::line(image, {grille.x, y}, {grille.br().x - 1, y}, cv::Scalar(rng.uniform(150, 220)), 1);
      }
      used = 0.8;
    }
    x += used + rng.uniform(0.15, 0.9);
  }
  for (int k = rng.uniform(1, 3); k > 0; --k) {
    const cv::Rect sign(rng.uniform(0, image.cols - static_cast<int>(3.5 * tpm)), ground_y - static_cast<int>(0.1 * tpm),
                        static_cast<int>(rng.uniform(1.5, 3.5) * tpm), static_cast<int>(0.3 * tpm));
    cv::rectangle(image, sign, cv::Scalar(rng.uniform(20, 60)), cv::FILLED);
    drawTextInBox(image, randomWord(rng, 2, 3), sign, 235, cv::FONT_HERSHEY_TRIPLEX, std::max(1, sign.height / 12));
  }
  // Drain pipes and climbing plants.
  for (int k = rng.uniform(1, 3); k > 0; --k) {
    const int x = rng.uniform(0, image.cols);
    cv::line(image, {x, 0}, {x, image.rows}, cv::Scalar(rng.uniform(30, 90)), std::max(2, static_cast<int>(0.08 * tpm)));
  }
  cv::Mat plant = fractalNoise(image.size(), 1.5 * tpm, 6, 0.6, rng);
  cv::Mat leaves = fractalNoise(image.size(), 0.1 * tpm, 3, 0.7, rng);
  cv::Mat plant_mask = plant > 0.55f;
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
      return f.level + ((static_cast<int>(std::floor((x * f.dx + y * f.dy) / f.period)) & 1) ? f.amplitude : -f.amplitude) + 6 * fine;
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

}  // namespace

cv::Mat terrain(int height, std::uint32_t seed) {
  cv::RNG rng(0x7e770000ULL + seed);
  const int width = 2 * height, margin = height / 8;
  // Patchwork of fields: a Voronoi partition with periodic seeds (copies shifted by +-width), so
  // that longitude 0 and 360 meet without a seam.
  const int fields = width * height / (110 * 110);
  cv::Mat seeds(height, width + 2 * margin, CV_8U, cv::Scalar(255));
  std::vector<cv::Point> centres;
  for (int k = 0; k < fields; ++k) centres.emplace_back(rng.uniform(0, width), rng.uniform(0, height));
  for (const cv::Point& c : centres) {
    for (int shift : {-width, 0, width}) {
      const int x = c.x + shift + margin;
      if (x >= 0 && x < seeds.cols) seeds.at<uchar>(c.y, x) = 0;
    }
  }
  cv::Mat distance, labels;
  cv::distanceTransform(seeds, distance, labels, cv::DIST_L2, cv::DIST_MASK_5, cv::DIST_LABEL_PIXEL);
  std::vector<int> field_of_label(static_cast<size_t>(fields) * 3 + 2, 0);
  for (int k = 0; k < fields; ++k) {
    for (int shift : {-width, 0, width}) {
      const int x = centres[static_cast<size_t>(k)].x + shift + margin;
      if (x < 0 || x >= seeds.cols) continue;
      const int label = labels.at<int>(centres[static_cast<size_t>(k)].y, x);
      if (label >= 0 && static_cast<size_t>(label) < field_of_label.size()) field_of_label[static_cast<size_t>(label)] = k;
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
      const int id = field_of_label[static_cast<size_t>(std::min<int>(label[x], static_cast<int>(field_of_label.size()) - 1))];
      float v = fieldValue(params[static_cast<size_t>(id)], x, y, noise[x]);
      // Hedges and tracks along the field borders.
      const int right = label[x + 1 < width + margin ? x + 1 : x], below = y + 1 < height ? labels.ptr<int>(y + 1)[margin + x] : label[x];
      if (field_of_label[static_cast<size_t>(std::min<int>(right, static_cast<int>(field_of_label.size()) - 1))] != id ||
          field_of_label[static_cast<size_t>(std::min<int>(below, static_cast<int>(field_of_label.size()) - 1))] != id) {
        v = 35;
      }
      out[x] = cv::saturate_cast<uchar>(v);
    }
  }
  cv::erode(image, image, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2, 2)));
  // Villages and roads, drawn three times (shifted by +-width) to wrap around.
  for (int k = 0; k < width * height / 60000; ++k) {
    const cv::Point c(rng.uniform(0, width), rng.uniform(0, height));
    for (int b = rng.uniform(3, 12); b > 0; --b) {
      const cv::Rect house(c.x + rng.uniform(-60, 60), c.y + rng.uniform(-60, 60), rng.uniform(8, 30), rng.uniform(8, 30));
      const cv::Scalar roof(rng.uniform(0, 2) ? rng.uniform(200, 250) : rng.uniform(20, 60));
      for (int shift : {-width, 0, width}) {
        cv::rectangle(image, house + cv::Point(shift, 0), roof, cv::FILLED);
        cv::line(image, house.tl() + cv::Point(shift, house.height / 2), house.br() + cv::Point(shift, -house.height / 2),
                 cv::Scalar(110), 1);
      }
    }
  }
  for (int k = 0; k < width * height / 200000; ++k) {
    std::vector<cv::Point> road = {{rng.uniform(0, width), rng.uniform(0, height)}};
    for (int s = 0; s < 8; ++s) road.push_back(road.back() + cv::Point(rng.uniform(-300, 300), rng.uniform(-300, 300)));
    const cv::Scalar colour(rng.uniform(0, 2) ? 215 : 25);
    for (int shift : {-width, 0, width}) {
      std::vector<cv::Point> shifted;
      for (const cv::Point& p : road) shifted.push_back(p + cv::Point(shift, 0));
      cv::polylines(image, shifted, false, colour, 5, cv::LINE_AA);
    }
  }
  cv::Mat as_float;
  image.convertTo(as_float, CV_32F);
  as_float += 25.0 * periodicNoise(image.size(), height / 5.0, 5, rng);
  as_float.convertTo(image, CV_8U);
  return image;
}

}  // namespace scale_drift_slam::sim::textures
