#include "scale_drift_slam/sim/texture_generator.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace scale_drift_slam::sim::textures {

cv::Mat fractalNoise(cv::Size size, double largest_period, int octaves, double persistence,
                     cv::RNG& rng) {
  cv::Mat sum = cv::Mat::zeros(size, CV_32F);
  double amplitude = 1.0, period = std::max(largest_period, 2.0), total = 0.0;
  for (int octave = 0; octave < octaves && period >= 1.5; ++octave) {
    const int cols = static_cast<int>(std::ceil(size.width / period)) + 2;
    const int rows = static_cast<int>(std::ceil(size.height / period)) + 2;
    cv::Mat grid(rows, cols, CV_32F);
    rng.fill(grid, cv::RNG::UNIFORM, -1.0, 1.0);
    cv::Mat layer;
    cv::resize(grid, layer, cv::Size(static_cast<int>((cols - 1) * period),
                                     static_cast<int>((rows - 1) * period)),
               0, 0, cv::INTER_CUBIC);
    sum += amplitude * layer(cv::Rect(0, 0, size.width, size.height));
    total += amplitude;
    amplitude *= persistence;
    period /= 2.0;
  }
  if (total > 0.0) sum /= total;
  return sum;
}

void addNoise(cv::Mat& image, double amplitude, double largest_period, int octaves, cv::RNG& rng) {
  cv::Mat noise = fractalNoise(image.size(), largest_period, octaves, 0.6, rng);
  cv::Mat as_float;
  image.convertTo(as_float, CV_32F);
  as_float += amplitude * noise;
  as_float.convertTo(image, CV_8U);
}

std::string randomWord(cv::RNG& rng, int min_syllables, int max_syllables) {
  static const char* kOnsets[] = {"b", "c",  "d",  "f", "g",  "h",  "k",  "l",  "m",  "n",  "p",
                                  "r", "s",  "t",  "v", "w",  "z",  "br", "cl", "dr", "gr", "pl",
                                  "st", "tr", "sh", "ch", "th", "qu", "sk", "fl", "bl", "cr"};
  static const char* kVowels[] = {"a", "e", "i", "o", "u", "ai", "ea", "ou", "io", "y"};
  static const char* kCodas[] = {"", "", "", "n", "r", "s", "l", "t", "m", "x", "nd", "rk"};
  const int syllables = rng.uniform(min_syllables, max_syllables + 1);
  std::string word;
  for (int i = 0; i < syllables; ++i) {
    word += kOnsets[rng.uniform(0, 32)];
    word += kVowels[rng.uniform(0, 10)];
    word += kCodas[rng.uniform(0, 12)];
  }
  word[0] = static_cast<char>(std::toupper(word[0]));
  return word;
}

void drawTextInBox(cv::Mat& image, const std::string& text, const cv::Rect& box, double grey,
                   int font, int thickness) {
  if (box.width < 4 || box.height < 4 || text.empty()) return;
  int baseline = 0;
  const cv::Size unit = cv::getTextSize(text, font, 1.0, thickness, &baseline);
  const double scale = std::min(box.width / static_cast<double>(unit.width),
                                box.height / static_cast<double>(unit.height + baseline));
  const cv::Size size = cv::getTextSize(text, font, scale, thickness, &baseline);
  const cv::Point origin(box.x + (box.width - size.width) / 2,
                         box.y + (box.height + size.height) / 2 - baseline / 2);
  cv::putText(image, text, origin, font, scale, cv::Scalar(grey), thickness, cv::LINE_AA);
}

namespace {

void drawRandomShape(cv::Mat& image, cv::RNG& rng) {
  const int w = image.cols, h = image.rows;
  const cv::Scalar grey(rng.uniform(0, 256));
  const cv::Point centre(rng.uniform(0, w), rng.uniform(0, h));
  const int size = std::max(2, rng.uniform(std::max(3, w / 20), std::max(4, w / 3)));
  switch (rng.uniform(0, 5)) {
    case 0:
      cv::circle(image, centre, size / 2, grey, cv::FILLED, cv::LINE_AA);
      break;
    case 1:
      cv::rectangle(image, cv::Rect(centre.x, centre.y, size, rng.uniform(2, size + 3)), grey,
                    cv::FILLED);
      break;
    case 2: {
      std::vector<cv::Point> triangle;
      for (int k = 0; k < 3; ++k) {
        triangle.emplace_back(centre.x + rng.uniform(-size, size), centre.y + rng.uniform(-size, size));
      }
      cv::fillConvexPoly(image, triangle, grey, cv::LINE_AA);
      break;
    }
    case 3:
      cv::line(image, centre, centre + cv::Point(rng.uniform(-size, size), rng.uniform(-size, size)),
               grey, std::max(1, size / 12), cv::LINE_AA);
      break;
    default:
      cv::ellipse(image, centre, cv::Size(size / 2, std::max(1, size / 4)), rng.uniform(0, 180), 0,
                  360, grey, std::max(1, size / 15), cv::LINE_AA);
  }
}

}  // namespace

cv::Mat poster(cv::Size size, cv::RNG& rng) {
  const int w = size.width, h = size.height;
  cv::Mat image(size, CV_8U);
  // Background: a gradient between two random greys.
  const double a = rng.uniform(30, 230), b = rng.uniform(30, 230);
  for (int y = 0; y < h; ++y) image.row(y).setTo(cv::Scalar(a + (b - a) * y / std::max(1, h - 1)));
  const int shapes = rng.uniform(4, 14);
  for (int i = 0; i < shapes; ++i) drawRandomShape(image, rng);
  // A "photograph": a high-contrast noise patch in a frame.
  if (rng.uniform(0, 2) == 0 && w > 16 && h > 16) {
    const cv::Rect photo(rng.uniform(0, w / 3), rng.uniform(h / 4, h / 2), w / 2, h / 3);
    cv::Mat patch = fractalNoise(photo.size(), photo.width / 3.0, 5, 0.65, rng);
    patch.convertTo(image(photo & cv::Rect(0, 0, w, h)), CV_8U, 160.0, 128.0);
  }
  const double ink = (a + b) / 2 > 128 ? rng.uniform(0, 60) : rng.uniform(190, 256);
  drawTextInBox(image, randomWord(rng, 2, 3), cv::Rect(w / 12, h / 20, w * 5 / 6, h / 6), ink,
                cv::FONT_HERSHEY_DUPLEX + rng.uniform(0, 2) * 2, std::max(1, h / 60));
  const int lines = rng.uniform(2, 7);
  for (int i = 0; i < lines; ++i) {
    const int line_h = std::max(3, h / 24);
    const int y = h * 2 / 3 + i * line_h * 3 / 2;
    if (y + line_h > h - 2) break;
    drawTextInBox(image, randomWord(rng, 1, 2) + " " + randomWord(rng, 1, 3) + " " +
                             randomWord(rng, 1, 2),
                  cv::Rect(w / 10, y, w * 4 / 5, line_h), ink, cv::FONT_HERSHEY_SIMPLEX, 1);
  }
  cv::rectangle(image, cv::Rect(0, 0, w, h), cv::Scalar(rng.uniform(0, 80)), std::max(1, w / 80));
  return image;
}

cv::Mat checkerboard(int cols, int rows, int square) {
  cv::Mat image((rows + 2) * square, (cols + 2) * square, CV_8U, cv::Scalar(255));
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      if ((r + c) % 2 == 0) {
        image(cv::Rect((c + 1) * square, (r + 1) * square, square, square)).setTo(cv::Scalar(0));
      }
    }
  }
  return image;
}

}  // namespace scale_drift_slam::sim::textures
