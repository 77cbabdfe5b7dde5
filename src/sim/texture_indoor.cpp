// Indoor materials: walls, floors, ceilings and furniture (sim/texture_generator.h).

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "scale_drift_slam/sim/texture_generator.h"

namespace scale_drift_slam::sim::textures {
namespace {

cv::Rect metres(double x, double y, double w, double h, double tpm) {
  return cv::Rect(static_cast<int>(x * tpm), static_cast<int>(y * tpm), static_cast<int>(w * tpm),
                  static_cast<int>(h * tpm));
}

void whiteboard(cv::Mat& image, const cv::Rect& box, cv::RNG& rng) {
  image(box).setTo(cv::Scalar(235));
  cv::rectangle(image, box, cv::Scalar(120), std::max(2, box.width / 80));
  for (int k = rng.uniform(4, 9); k > 0; --k) {
    const cv::Rect line(box.x + rng.uniform(box.width / 20, box.width / 2),
                        box.y + rng.uniform(box.height / 10, box.height * 4 / 5),
                        rng.uniform(box.width / 6, box.width / 2), box.height / 12);
    drawTextInBox(image, randomWord(rng, 1, 3) + " = " + randomWord(rng, 1, 2), line & box,
                  rng.uniform(20, 90), cv::FONT_HERSHEY_SCRIPT_SIMPLEX, 1);
  }
  std::vector<cv::Point> curve;
  for (int i = 0; i < 30; ++i) {
    curve.emplace_back(
        box.x + box.width / 10 + i * box.width / 40,
        box.y + box.height / 2 + static_cast<int>(box.height / 5 * std::sin(i * 0.4)));
  }
  cv::polylines(image, curve, false, cv::Scalar(40), 2, cv::LINE_AA);
}

void bookshelf(cv::Mat& image, const cv::Rect& box, cv::RNG& rng) {
  image(box).setTo(cv::Scalar(70));
  const int shelves = 5, shelf_h = box.height / shelves;
  for (int s = 0; s < shelves; ++s) {
    const int y = box.y + s * shelf_h;
    cv::rectangle(image, cv::Rect(box.x, y, box.width, shelf_h / 10 + 1), cv::Scalar(150),
                  cv::FILLED);
    for (int x = box.x + 2; x < box.br().x - 4;) {
      const int w = rng.uniform(std::max(2, box.width / 60), std::max(3, box.width / 18));
      const int h = rng.uniform(shelf_h * 5 / 10, shelf_h * 9 / 10);
      const cv::Rect spine(x, y + shelf_h - h, std::min(w, box.br().x - x - 1), h);
      cv::rectangle(image, spine, cv::Scalar(rng.uniform(20, 240)), cv::FILLED);
      if (rng.uniform(0, 3) == 0) {
        cv::line(image, {spine.x, spine.y + h / 5}, {spine.br().x, spine.y + h / 5},
                 cv::Scalar(rng.uniform(0, 256)), 1);
      }
      x += w + 1;
    }
  }
}

void radiator(cv::Mat& image, const cv::Rect& box) {
  image(box).setTo(cv::Scalar(215));
  for (int x = box.x; x < box.br().x; x += std::max(3, box.width / 24)) {
    cv::line(image, {x, box.y}, {x, box.br().y}, cv::Scalar(150), 1);
  }
}

/// Pastes `item` onto `image` centred at `centre`, turned by `angle_deg` (things lie askew on a
/// desk; axis-aligned papers would give corners along only two directions).
void pasteTurned(cv::Mat& image, const cv::Mat& item, cv::Point2f centre, double angle_deg) {
  cv::Mat M =
      cv::getRotationMatrix2D(cv::Point2f(item.cols / 2.0f, item.rows / 2.0f), angle_deg, 1.0);
  M.at<double>(0, 2) += centre.x - item.cols / 2.0;
  M.at<double>(1, 2) += centre.y - item.rows / 2.0;
  // BORDER_TRANSPARENT leaves the desk where the item is not.
  cv::warpAffine(item, image, M, image.size(), cv::INTER_LINEAR, cv::BORDER_TRANSPARENT);
}

/// A keyboard: a dark body with five rows of keys, each with a letter (repetitive structure).
cv::Mat keyboard(double tpm, cv::RNG& rng) {
  cv::Mat image(static_cast<int>(0.16 * tpm), static_cast<int>(0.45 * tpm), CV_8U,
                cv::Scalar(rng.uniform(25, 55)));
  const int rows = 5, cols = 15;
  const double kw = (image.cols - 8.0) / cols, kh = (image.rows - 8.0) / rows;
  const double key_grey = rng.uniform(150, 210);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const cv::Rect key(static_cast<int>(4 + c * kw + (r % 2) * kw / 3),
                         static_cast<int>(4 + r * kh), static_cast<int>(kw - 3),
                         static_cast<int>(kh - 3));
      const cv::Rect clipped = key & cv::Rect(0, 0, image.cols, image.rows);
      cv::rectangle(image, clipped, cv::Scalar(key_grey + rng.uniform(-8, 8)), cv::FILLED);
      drawTextInBox(image, std::string(1, static_cast<char>('A' + rng.uniform(0, 26))),
                    cv::Rect(clipped.x + clipped.width / 4, clipped.y + clipped.height / 4,
                             clipped.width / 2, clipped.height / 2),
                    40, cv::FONT_HERSHEY_SIMPLEX, 1);
    }
  }
  return image;
}

/// A lined notebook page with handwriting, or a sticky note: bright paper with a few words.
cv::Mat note(cv::Size size, bool lined, cv::RNG& rng) {
  cv::Mat image(size, CV_8U, cv::Scalar(rng.uniform(205, 245)));
  const int line_h = std::max(6, size.height / (lined ? 18 : 5));
  for (int y = line_h; y < size.height - line_h / 2; y += line_h) {
    if (lined) cv::line(image, {0, y}, {size.width, y}, cv::Scalar(150), 1);
    if (rng.uniform(0, 3) > 0) {
      drawTextInBox(image, randomWord(rng, 1, 3) + " " + randomWord(rng, 1, 2),
                    cv::Rect(size.width / 10, y - line_h + 2,
                             rng.uniform(size.width / 3, size.width * 4 / 5), line_h - 3),
                    rng.uniform(10, 90), cv::FONT_HERSHEY_SCRIPT_SIMPLEX, 1);
    }
  }
  cv::rectangle(image, cv::Rect(0, 0, size.width, size.height), cv::Scalar(120), 1);
  return image;
}

/// Small things: pens, a coffee ring, a cable, a mouse on its pad.
void deskClutter(cv::Mat& image, double tpm, cv::RNG& rng) {
  for (int k = rng.uniform(3, 6); k > 0; --k) {  // pens and pencils
    const cv::Point a(rng.uniform(0, image.cols), rng.uniform(0, image.rows));
    const double angle = rng.uniform(0.0, M_PI), length = rng.uniform(0.12, 0.16) * tpm;
    const cv::Point b(a.x + static_cast<int>(length * std::cos(angle)),
                      a.y + static_cast<int>(length * std::sin(angle)));
    cv::line(image, a, b, cv::Scalar(rng.uniform(0, 60)), std::max(2, int(0.008 * tpm)),
             cv::LINE_AA);
  }
  const cv::Point ring(rng.uniform(0, image.cols), rng.uniform(0, image.rows));
  cv::circle(image, ring, static_cast<int>(0.04 * tpm), cv::Scalar(rng.uniform(60, 100)), 2,
             cv::LINE_AA);
  std::vector<cv::Point> cable;
  double x = rng.uniform(0, image.cols), y = 0, heading = M_PI / 2;
  while (y < image.rows && x > 0 && x < image.cols) {
    cable.emplace_back(static_cast<int>(x), static_cast<int>(y));
    heading += rng.uniform(-0.3, 0.3);
    x += 0.02 * tpm * std::cos(heading);
    y += 0.02 * tpm * std::max(0.3, std::sin(heading));
  }
  cv::polylines(image, cable, false, cv::Scalar(20), std::max(2, int(0.006 * tpm)), cv::LINE_AA);
  const cv::Rect pad(rng.uniform(image.cols / 2, image.cols * 3 / 4),
                     rng.uniform(0, image.rows / 2), static_cast<int>(0.25 * tpm),
                     static_cast<int>(0.2 * tpm));
  cv::rectangle(image, pad & cv::Rect(0, 0, image.cols, image.rows),
                cv::Scalar(rng.uniform(30, 70)), cv::FILLED);
  cv::ellipse(image, cv::Point(pad.x + pad.width / 2, pad.y + pad.height / 2),
              cv::Size(static_cast<int>(0.03 * tpm), static_cast<int>(0.05 * tpm)), 0, 0, 360,
              cv::Scalar(200), cv::FILLED, cv::LINE_AA);
}

}  // namespace

cv::Mat interiorWall(double width_m, double height_m, double texels_per_metre, std::uint32_t seed,
                     bool with_door) {
  cv::RNG rng(0x1a11000ULL + seed);
  const double tpm = texels_per_metre;
  cv::Mat image(static_cast<int>(height_m * tpm), static_cast<int>(width_m * tpm), CV_8U,
                cv::Scalar(rng.uniform(170, 225)));
  addNoise(image, 10, 1.0 * tpm, 4, rng);  // paint: weakly textured
  // Skirting board.
  cv::rectangle(image, metres(0, height_m - 0.1, width_m, 0.1, tpm),
                cv::Scalar(rng.uniform(60, 120)), cv::FILLED);
  double x = rng.uniform(0.2, 0.8);
  if (with_door) {
    const cv::Rect door = metres(x, height_m - 2.05, 0.9, 2.05, tpm);
    cv::Mat wood = fractalNoise(door.size(), door.width / 5.0, 4, 0.5, rng);
    wood.convertTo(image(door), CV_8U, 30, rng.uniform(80, 150));
    cv::circle(image, {door.br().x - door.width / 8, door.y + door.height / 2},
               std::max(2, door.width / 25), cv::Scalar(230), cv::FILLED, cv::LINE_AA);
    cv::rectangle(image, door, cv::Scalar(60), std::max(2, door.width / 30));
    x += 1.3;
  }
  while (x < width_m - 0.9) {
    const int kind = rng.uniform(0, 5);
    if (kind == 0 && x < width_m - 2.0) {
      whiteboard(image, metres(x, 0.8, 1.6, 1.0, tpm), rng);
      x += 1.6;
    } else if (kind == 1 && x < width_m - 1.1) {
      bookshelf(image, metres(x, height_m - 2.0, 1.0, 1.9, tpm), rng);
      x += 1.0;
    } else if (kind == 2) {
      radiator(image, metres(x, height_m - 0.75, 0.8, 0.5, tpm));
      x += 0.8;
    } else {
      const double w = rng.uniform(0.4, 0.8), h = rng.uniform(0.5, 0.9);
      const cv::Rect frame = metres(x, rng.uniform(0.6, 1.1), w, h, tpm);
      poster(frame.size(), rng).copyTo(image(frame));
      cv::rectangle(image, frame, cv::Scalar(rng.uniform(10, 60)), std::max(2, frame.width / 40));
      x += w;
    }
    x += rng.uniform(0.3, 1.2);
  }
  addNoise(image, 6, 0.02 * tpm, 2, rng);
  return image;
}

cv::Mat floorMaterial(const std::string& kind, double width_m, double depth_m,
                      double texels_per_metre, std::uint32_t seed) {
  cv::RNG rng(0xf100000ULL + seed);
  const double tpm = texels_per_metre;
  cv::Mat image(static_cast<int>(depth_m * tpm), static_cast<int>(width_m * tpm), CV_8U,
                cv::Scalar(rng.uniform(90, 160)));
  if (kind == "carpet") {
    addNoise(image, 35, 0.04 * tpm, 3, rng);
    addNoise(image, 30, 1.5 * tpm, 4, rng);
  } else if (kind == "wood") {
    const double plank_w = 0.15 * tpm;
    for (double y = 0; y < image.rows; y += plank_w) {
      for (double x = -rng.uniform(0.0, 1.2) * tpm; x < image.cols;) {
        const double len = rng.uniform(0.8, 1.6) * tpm;
        cv::rectangle(image,
                      cv::Rect(static_cast<int>(x), static_cast<int>(y), static_cast<int>(len),
                               static_cast<int>(plank_w)),
                      cv::Scalar(rng.uniform(90, 170)), cv::FILLED);
        cv::rectangle(image,
                      cv::Rect(static_cast<int>(x), static_cast<int>(y), static_cast<int>(len),
                               static_cast<int>(plank_w)),
                      cv::Scalar(50), 1);
        x += len;
      }
    }
    cv::Mat grain = fractalNoise(cv::Size(image.cols / 8 + 1, image.rows), 6.0, 3, 0.6, rng);
    cv::Mat grain_wide;
    cv::resize(grain, grain_wide, image.size());
    cv::Mat as_float;
    image.convertTo(as_float, CV_32F);
    as_float += 25 * grain_wide;
    as_float.convertTo(image, CV_8U);
  } else if (kind == "tiles" || kind == "ceiling") {
    const double tile = (kind == "tiles" ? 0.3 : 0.6) * tpm;
    for (double y = 0; y < image.rows; y += tile) {
      for (double x = 0; x < image.cols; x += tile) {
        const int level = kind == "tiles" ? rng.uniform(80, 200) : rng.uniform(205, 225);
        cv::rectangle(image,
                      cv::Rect(static_cast<int>(x), static_cast<int>(y), static_cast<int>(tile),
                               static_cast<int>(tile)),
                      cv::Scalar(level), cv::FILLED);
        cv::rectangle(image,
                      cv::Rect(static_cast<int>(x), static_cast<int>(y), static_cast<int>(tile),
                               static_cast<int>(tile)),
                      cv::Scalar(kind == "tiles" ? 60 : 150), 2);
        if (kind == "ceiling" && rng.uniform(0, 7) == 0) {  // a light
          cv::rectangle(image,
                        cv::Rect(static_cast<int>(x + tile / 8), static_cast<int>(y + tile / 8),
                                 static_cast<int>(tile * 3 / 4), static_cast<int>(tile * 3 / 4)),
                        cv::Scalar(252), cv::FILLED);
        }
      }
    }
    addNoise(image, kind == "tiles" ? 18 : 6, 0.5 * tpm, 4, rng);
  } else {
    throw std::invalid_argument("unknown floor material '" + kind + "'");
  }
  return image;
}

cv::Mat furniture(const std::string& kind, double width_m, double height_m, double texels_per_metre,
                  std::uint32_t seed) {
  cv::RNG rng(0xfa00000ULL + seed);
  const double tpm = texels_per_metre;
  const cv::Size size(std::max(4, static_cast<int>(width_m * tpm)),
                      std::max(4, static_cast<int>(height_m * tpm)));
  cv::Mat image(size, CV_8U, cv::Scalar(rng.uniform(90, 170)));
  if (kind == "desk") {
    addNoise(image, 25, 0.3 * tpm, 4, rng);
    for (int k = rng.uniform(2, 5); k > 0; --k) {  // papers and books
      const cv::Size paper(static_cast<int>(0.21 * tpm), static_cast<int>(0.297 * tpm));
      const cv::Point at(rng.uniform(0, std::max(1, size.width - paper.width)),
                         rng.uniform(0, std::max(1, size.height - paper.height)));
      poster(paper, rng)
          .copyTo(image(cv::Rect(at, paper) & cv::Rect(0, 0, size.width, size.height)));
    }
    const cv::Rect keyboard = metres(width_m / 2 - 0.22, height_m * 0.55, 0.44, 0.15, tpm) &
                              cv::Rect(0, 0, size.width, size.height);
    image(keyboard).setTo(cv::Scalar(40));
    for (int r = 0; r < 5; ++r) {
      for (int c = 0; c < 15; ++c) {  // repetitive keys
        cv::rectangle(image,
                      cv::Rect(keyboard.x + 2 + c * keyboard.width / 15,
                               keyboard.y + 2 + r * keyboard.height / 5, keyboard.width / 15 - 3,
                               keyboard.height / 5 - 3),
                      cv::Scalar(rng.uniform(150, 200)), cv::FILLED);
      }
    }
  } else if (kind == "cabinet") {
    addNoise(image, 12, 0.5 * tpm, 3, rng);
    const int doors = std::max(1, static_cast<int>(width_m / 0.5));
    for (int d = 0; d < doors; ++d) {
      const cv::Rect door(d * size.width / doors + 3, 3, size.width / doors - 6, size.height - 6);
      cv::rectangle(image, door, cv::Scalar(50), 2);
      cv::rectangle(image,
                    cv::Rect(door.x + door.width / 2 - 2, door.y + door.height / 8,
                             std::max(4, door.width / 3), 5),
                    cv::Scalar(230), cv::FILLED);
    }
    drawTextInBox(image, randomWord(rng, 1, 2),
                  cv::Rect(size.width / 4, size.height / 2, size.width / 2, size.height / 10), 20,
                  cv::FONT_HERSHEY_SIMPLEX, 1);
  } else if (kind == "books") {
    bookshelf(image, cv::Rect(0, 0, size.width, size.height), rng);
  } else if (kind == "screen") {
    image.setTo(cv::Scalar(25));
    const cv::Rect display(size.width / 20, size.height / 20, size.width * 9 / 10,
                           size.height * 9 / 10);
    image(display).setTo(cv::Scalar(rng.uniform(40, 90)));
    for (int k = rng.uniform(2, 4); k > 0; --k) {
      const cv::Rect window(display.x + rng.uniform(0, display.width / 2),
                            display.y + rng.uniform(0, display.height / 2), display.width / 2,
                            display.height / 2);
      const cv::Rect clipped = window & display;
      poster(clipped.size(), rng).copyTo(image(clipped));
    }
  } else {
    throw std::invalid_argument("unknown furniture '" + kind + "'");
  }
  return image;
}

cv::Mat deskTop(double width_m, double depth_m, double texels_per_metre, std::uint32_t seed) {
  cv::RNG rng(0xde50000ULL + seed);
  const double tpm = texels_per_metre;
  const cv::Size size(static_cast<int>(width_m * tpm), static_cast<int>(depth_m * tpm));
  // Wood: grain stretched along x over broad light-dark bands (the veneer).
  cv::Mat grain = fractalNoise(cv::Size(size.width / 16 + 1, size.height), 4.0, 3, 0.6, rng);
  cv::Mat grain_wide;
  cv::resize(grain, grain_wide, size);
  cv::Mat wood =
      18 * grain_wide + 14 * fractalNoise(size, 0.4 * tpm, 3, 0.5, rng) + rng.uniform(120.0, 165.0);
  cv::Mat image;
  wood.convertTo(image, CV_8U);
  auto anywhere = [&](double margin_m) {
    const int m = static_cast<int>(margin_m * tpm);
    return cv::Point2f(rng.uniform(m, std::max(m + 1, size.width - m)),
                       rng.uniform(m, std::max(m + 1, size.height - m)));
  };
  for (int k = rng.uniform(4, 7); k > 0; --k) {  // papers, some printed, some notebooks
    const cv::Size a4(static_cast<int>(0.21 * tpm), static_cast<int>(0.297 * tpm));
    const cv::Mat paper = rng.uniform(0, 3) == 0 ? note(a4, true, rng) : poster(a4, rng);
    pasteTurned(image, paper, anywhere(0.1), rng.uniform(-40.0, 40.0));
  }
  for (int k = rng.uniform(3, 6); k > 0; --k) {  // sticky notes
    const int side = static_cast<int>(0.076 * tpm);
    pasteTurned(image, note(cv::Size(side, side), false, rng), anywhere(0.05),
                rng.uniform(-25.0, 25.0));
  }
  pasteTurned(image, keyboard(tpm, rng),
              cv::Point2f(size.width * rng.uniform(0.35f, 0.55f), size.height * 0.45f),
              rng.uniform(-8.0, 8.0));
  deskClutter(image, tpm, rng);
  addNoise(image, 5, 0.01 * tpm, 2, rng);
  return image;
}

}  // namespace scale_drift_slam::sim::textures
