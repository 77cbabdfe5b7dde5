#include "scale_drift_slam/io/plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace scale_drift_slam::io {
namespace {

/// A "nice" tick spacing (1, 2 or 5 times a power of ten) giving about `count` ticks.
double tickStep(double range, int count) {
  const double raw = range / std::max(1, count);
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  for (double nice : {1.0, 2.0, 5.0, 10.0}) {
    if (raw <= nice * magnitude) return nice * magnitude;
  }
  return 10.0 * magnitude;
}

std::string formatTick(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%g", std::abs(value) < 1e-12 ? 0.0 : value);
  return buffer;
}

}  // namespace

cv::Scalar plotColor(int index) {
  static const cv::Scalar kColors[] = {{40, 40, 200},  {200, 120, 30}, {40, 160, 40},
                                       {30, 30, 30},   {170, 50, 170}, {20, 140, 220},
                                       {160, 160, 40}, {120, 120, 120}};
  return kColors[index % 8];
}

cv::Mat renderPlot(const std::vector<PlotSeries>& series, const PlotOptions& options) {
  cv::Mat image(options.height, options.width, CV_8UC3, cv::Scalar(255, 255, 255));
  const int left = 80, right = 30, top = 50, bottom = 60;
  const int plot_w = options.width - left - right, plot_h = options.height - top - bottom;

  Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector2d hi = -lo;
  for (const PlotSeries& s : series) {
    for (const Eigen::Vector2d& p : s.points) {
      if (!p.allFinite()) continue;
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  }
  if (!lo.allFinite()) lo = Eigen::Vector2d(0, 0), hi = Eigen::Vector2d(1, 1);
  Eigen::Vector2d span = (hi - lo).cwiseMax(1e-9);
  lo -= 0.05 * span;
  hi += 0.05 * span;
  span = hi - lo;
  Eigen::Vector2d scale(plot_w / span.x(), plot_h / span.y());
  if (options.equal_axes) {
    const double s = std::min(scale.x(), scale.y());
    const Eigen::Vector2d centre = 0.5 * (lo + hi);
    scale = Eigen::Vector2d(s, s);
    lo = centre - Eigen::Vector2d(plot_w / s, plot_h / s) / 2;
    hi = centre + Eigen::Vector2d(plot_w / s, plot_h / s) / 2;
  }
  auto to_pixel = [&](const Eigen::Vector2d& p) {
    return cv::Point(static_cast<int>(std::lround(left + (p.x() - lo.x()) * scale.x())),
                     static_cast<int>(std::lround(top + plot_h - (p.y() - lo.y()) * scale.y())));
  };

  // Grid, ticks and labels.
  const cv::Scalar grid(230, 230, 230), ink(60, 60, 60);
  const double x_step = tickStep(hi.x() - lo.x(), 8), y_step = tickStep(hi.y() - lo.y(), 8);
  for (double x = std::ceil(lo.x() / x_step) * x_step; x <= hi.x(); x += x_step) {
    const cv::Point a = to_pixel({x, lo.y()}), b = to_pixel({x, hi.y()});
    cv::line(image, a, b, grid, 1);
    cv::putText(image, formatTick(x), a + cv::Point(-12, 20), cv::FONT_HERSHEY_SIMPLEX, 0.45, ink);
  }
  for (double y = std::ceil(lo.y() / y_step) * y_step; y <= hi.y(); y += y_step) {
    const cv::Point a = to_pixel({lo.x(), y}), b = to_pixel({hi.x(), y});
    cv::line(image, a, b, grid, 1);
    cv::putText(image, formatTick(y), a + cv::Point(-70, 5), cv::FONT_HERSHEY_SIMPLEX, 0.45, ink);
  }
  cv::rectangle(image, cv::Rect(left, top, plot_w, plot_h), ink, 1);
  cv::putText(image, options.title, cv::Point(left, 32), cv::FONT_HERSHEY_SIMPLEX, 0.7, ink, 2);
  cv::putText(image, options.x_label, cv::Point(left + plot_w / 2 - 20, options.height - 15),
              cv::FONT_HERSHEY_SIMPLEX, 0.55, ink, 1);
  cv::putText(image, options.y_label, cv::Point(8, top - 10), cv::FONT_HERSHEY_SIMPLEX, 0.55, ink,
              1);

  // Series, then the legend on top.
  for (const PlotSeries& s : series) {
    std::vector<cv::Point> pixels;
    for (const Eigen::Vector2d& p : s.points) {
      if (p.allFinite()) pixels.push_back(to_pixel(p));
    }
    if (s.dots) {
      for (const cv::Point& p : pixels)
        cv::circle(image, p, s.thickness, s.color, cv::FILLED);
    } else if (pixels.size() >= 2) {
      cv::polylines(image, pixels, false, s.color, s.thickness, cv::LINE_AA);
    }
  }
  int legend_y = top + 22;
  for (const PlotSeries& s : series) {
    if (s.label.empty()) continue;
    cv::line(image, {left + 12, legend_y - 5}, {left + 40, legend_y - 5}, s.color, 3);
    cv::putText(image, s.label, {left + 48, legend_y}, cv::FONT_HERSHEY_SIMPLEX, 0.5, ink, 1);
    legend_y += 22;
  }
  return image;
}

void savePlot(const std::string& path, const std::vector<PlotSeries>& series,
              const PlotOptions& options) {
  const cv::Mat image = renderPlot(series, options);
  bool written = false;
  try {
    written = cv::imwrite(path, image);
  } catch (const cv::Exception&) {
    written = false;
  }
  if (!written) throw std::runtime_error("cannot write plot '" + path + "'");
}

}  // namespace scale_drift_slam::io
