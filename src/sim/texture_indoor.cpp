// Indoor materials: walls, floors, ceilings and furniture (sim/texture_generator.h).

#include <algorithm>
#include <cmath>

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
    drawTextInBox(image, randomWord(rng, 1, 3) + " = " + randomWord(rng, 1, 2),
                  line & box, rng.uniform(20, 90), cv::FONT_HERSHEY_SCRIPT_SIMPLEX, 1);
  }
  std::vector<cv::Point> curve;
  for (int i = 0; i < 30; ++i) {
    curve.emplace_back(box.x + box.width / 10 + i * box.width / 40,
                       box.y + box.height / 2 + static_cast<int>(box.height / 5 * std::sin(i * 0.4)));
  }
  cv::polylines(image, curve, false, cv::Scalar(40), 2, cv::LINE_AA);
}

void bookshelf(cv::Mat& image, const cv::Rect& box, cv::RNG& rng) {
  image(box).setTo(cv::Scalar(70));
  const int shelves = 5, shelf_h = box.height / shelves;
  for (int s = 0; s < shelves; ++s) {
    const int y = box.y + s * shelf_h;
    cv::rectangle(image, cv::Rect(box.x, y, box.width, shelf_h / 10 + 1), cv::Scalar(150), cv::FILLED);
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

}  // namespace

cv::Mat interiorWall(double width_m, double height_m, double texels_per_metre, std::uint32_t seed,
                     bool with_door) {
  cv::RNG rng(0x1a11000ULL + seed);
  const double tpm = texels_per_metre;
  cv::Mat image(static_cast<int>(height_m * tpm), static_cast<int>(width_m * tpm), CV_8U,
                cv::Scalar(rng.uniform(170, 225)));
  addNoise(image, 10, 1.0 * tpm, 4, rng);  // paint: weakly textured
  // Skirting board.
  cv::rectangle(image, metres(0, height_m - 0.1, width_m, 0.1, tpm), cv::Scalar(rng.uniform(60, 120)), cv::FILLED);
  double x = rng.uniform(0.2, 0.8);
  if (with_door) {
    const cv::Rect door = metres(x, height_m - 2.05, 0.9, 2.05, tpm);
    cv::Mat wood = fractalNoise(door.size(), door.width / 5.0, 4, 0.5, rng);
    wood.convertTo(image(door), CV_8U, 30, rng.uniform(80, 150));
    cv::circle(image, {door.br().x - door.width / 8, door.y + door.height / 2}, std::max(2, door.width / 25),
               cv::Scalar(230), cv::FILLED, cv::LINE_AA);
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
        cv::rectangle(image, cv::Rect(static_cast<int>(x), static_cast<int>(y), static_cast<int>(len),
                                      static_cast<int>(plank_w)),
                      cv::Scalar(rng.uniform(90, 170)), cv::FILLED);
        cv::rectangle(image, cv::Rect(static_cast<int>(x), static_cast<int>(y), static_cast<int>(len),
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
        cv::rectangle(image, cv::Rect(static_cast<int>(x), static_cast<int>(y), static_cast<int>(tile),
                                      static_cast<int>(tile)),
                      cv::Scalar(level), cv::FILLED);
        cv::rectangle(image, cv::Rect(static_cast<int>(x), static_cast<int>(y), static_cast<int>(tile),
                                      static_cast<int>(tile)),
                      cv::Scalar(kind == "tiles" ? 60 : 150), 2);
        if (kind == "ceiling" && rng.uniform(0, 7) == 0) {  // a light
          cv::rectangle(image, cv::Rect(static_cast<int>(x + tile / 8), static_cast<int>(y + tile / 8),
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

cv::Mat furniture(const std::string& kind, double width_m, double height_m,
                  double texels_per_metre, std::uint32_t seed) {
  cv::RNG rng(0xfa00000ULL + seed);
  const double tpm = texels_per_metre;
  const cv::Size size(std::max(4, static_cast<int>(width_m * tpm)), std::max(4, static_cast<int>(height_m * tpm)));
  cv::Mat image(size, CV_8U, cv::Scalar(rng.uniform(90, 170)));
  if (kind == "desk") {
    addNoise(image, 25, 0.3 * tpm, 4, rng);
    for (int k = rng.uniform(2, 5); k > 0; --k) {  // papers and books
      const cv::Size paper(static_cast<int>(0.21 * tpm), static_cast<int>(0.297 * tpm));
      const cv::Point at(rng.uniform(0, std::max(1, size.width - paper.width)),
                         rng.uniform(0, std::max(1, size.height - paper.height)));
      poster(paper, rng).copyTo(image(cv::Rect(at, paper) & cv::Rect(0, 0, size.width, size.height)));
    }
    const cv::Rect keyboard = metres(width_m / 2 - 0.22, height_m * 0.55, 0.44, 0.15, tpm) &
                              cv::Rect(0, 0, size.width, size.height);
    image(keyboard).setTo(cv::Scalar(40));
    for (int r = 0; r < 5; ++r) {
      for (int c = 0; c < 15; ++c) {  // repetitive keys
        cv::rectangle(image, cv::Rect(keyboard.x + 2 + c * keyboard.width / 15, keyboard.y + 2 + r * keyboard.height / 5,
                                      keyboard.width / 15 - 3, keyboard.height / 5 - 3),
                      cv::Scalar(rng.uniform(150, 200)), cv::FILLED);
      }
    }
  } else if (kind == "cabinet") {
    addNoise(image, 12, 0.5 * tpm, 3, rng);
    const int doors = std::max(1, static_cast<int>(width_m / 0.5));
    for (int d = 0; d < doors; ++d) {
      const cv::Rect door(d * size.width / doors + 3, 3, size.width / doors - 6, size.height - 6);
      cv::rectangle(image, door, cv::Scalar(50), 2);
      cv::rectangle(image, cv::Rect(door.x + door.width / 2 - 2, door.y + door.height / 8, std::max(4, door.width / 3), 5),
                    cv::Scalar(230), cv::FILLED);
    }
    drawTextInBox(image, randomWord(rng, 1, 2), cv::Rect(size.width / 4, size.height / 2, size.width / 2, size.height / 10),
                  20, cv::FONT_HERSHEY_SIMPLEX, 1);
  } else if (kind == "books") {
    bookshelf(image, cv::Rect(0, 0, size.width, size.height), rng);
  } else if (kind == "screen") {
    image.setTo(cv::Scalar(25));
    const cv::Rect display(size.width / 20, size.height / 20, size.width * 9 / 10, size.height * 9 / 10);
    image(display).setTo(cv::Scalar(rng.uniform(40, 90)));
    for (int k = rng.uniform(2, 4); k > 0; --k) {
      const cv::Rect window(display.x + rng.uniform(0, display.width / 2), display.y + rng.uniform(0, display.height / 2),
                            display.width / 2, display.height / 2);
      const cv::Rect clipped = window & display;
      poster(clipped.size(), rng).copyTo(image(clipped));
    }
  } else {
    throw std::invalid_argument("unknown furniture '" + kind + "'");
  }
  return image;
}

}  // namespace scale_drift_slam::sim::textures
