#pragma once
// Line plots written as PNG with OpenCV drawing (no plotting library is needed): trajectory top
// views and error curves for the experiment and evaluation tools.

#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace scale_drift_slam::io {

struct PlotSeries {
  std::string label;
  std::vector<Eigen::Vector2d> points;
  cv::Scalar color{0, 0, 0};  ///< BGR.
  int thickness = 2;
  bool dots = false;  ///< Draw each point as a dot instead of joining them.
};

struct PlotOptions {
  std::string title;
  std::string x_label = "x";
  std::string y_label = "y";
  int width = 1000;
  int height = 800;
  bool equal_axes = true;  ///< One unit is the same length on both axes (for top views).
};

/// Colours that stay apart for up to eight series (BGR).
cv::Scalar plotColor(int index);

/// Renders the series into an image (white background, axes with ticks, legend).
cv::Mat renderPlot(const std::vector<PlotSeries>& series, const PlotOptions& options);
/// Renders and writes a PNG. Throws std::runtime_error when the file cannot be written.
void savePlot(const std::string& path, const std::vector<PlotSeries>& series,
              const PlotOptions& options);

}  // namespace scale_drift_slam::io
