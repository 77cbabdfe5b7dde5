#pragma once
// Procedural images with a known answer for the place-recognition tests and benchmark: a long
// "wall" texture (random polygons, ellipses, lines and letters over smooth noise, unique
// everywhere for a given seed) seen by a virtual camera at a chosen place with a chosen small
// rotation, scale, tilt, lighting change and noise. Two views overlap exactly as much as their
// places on the wall do. Header-only, tests and benchmarks only.

#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace scale_drift_slam::loop::testing {

/// A grey texture of the given size, different for every seed.
inline cv::Mat makeTexture(int width, int height, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  // Smooth background: upsampled coarse noise.
  cv::Mat coarse(std::max(2, height / 40), std::max(2, width / 40), CV_32F);
  cv::theRNG().state = seed;  // cv::randu draws from OpenCV's global generator: seed it
  cv::randu(coarse, 60.0, 190.0);
  cv::Mat background;
  cv::resize(coarse, background, cv::Size(width, height), 0, 0, cv::INTER_CUBIC);
  cv::Mat image;
  background.convertTo(image, CV_8U);

  const int shapes = width * height / 900;
  for (int i = 0; i < shapes; ++i) {
    const cv::Point centre(static_cast<int>(unit(rng) * width),
                           static_cast<int>(unit(rng) * height));
    const cv::Scalar grey(unit(rng) * 255.0);
    const double size = 4.0 + 30.0 * std::pow(unit(rng), 2.0);
    switch (static_cast<int>(unit(rng) * 4.0)) {
      case 0: {  // polygon
        std::vector<cv::Point> corners;
        const int n = 3 + static_cast<int>(unit(rng) * 4.0);
        for (int k = 0; k < n; ++k) {
          const double angle = 2.0 * M_PI * (k + 0.6 * unit(rng)) / n;
          const double radius = size * (0.5 + unit(rng));
          corners.emplace_back(centre.x + static_cast<int>(radius * std::cos(angle)),
                               centre.y + static_cast<int>(radius * std::sin(angle)));
        }
        cv::fillPoly(image, std::vector<std::vector<cv::Point>>{corners}, grey, cv::LINE_AA);
        break;
      }
      case 1:
        cv::ellipse(image, centre,
                    cv::Size(static_cast<int>(size), static_cast<int>(size * unit(rng)) + 2),
                    unit(rng) * 180.0, 0.0, 360.0, grey, -1, cv::LINE_AA);
        break;
      case 2: {
        const cv::Point end(centre.x + static_cast<int>(3.0 * size * (unit(rng) - 0.5)),
                            centre.y + static_cast<int>(3.0 * size * (unit(rng) - 0.5)));
        cv::line(image, centre, end, grey, 1 + static_cast<int>(unit(rng) * 3.0), cv::LINE_AA);
        break;
      }
      default: {
        std::string word;
        const int letters = 1 + static_cast<int>(unit(rng) * 4.0);
        for (int k = 0; k < letters; ++k)
          word += static_cast<char>('A' + unit(rng) * 26.0);
        cv::putText(image, word, centre, cv::FONT_HERSHEY_SIMPLEX, 0.3 + size / 25.0, grey,
                    1 + static_cast<int>(unit(rng) * 2.0), cv::LINE_AA);
        break;
      }
    }
  }
  cv::GaussianBlur(image, image, cv::Size(3, 3), 0.7);
  return image;
}

/// How a virtual camera sees a texture: the view centre on the texture, an in-plane rotation,
/// a zoom, a perspective tilt (a few 1e-4 is a mild one), a lighting change and pixel noise.
struct ViewPose {
  double x = 0.0;
  double y = 0.0;
  double angle_deg = 0.0;
  double scale = 1.0;
  double tilt_x = 0.0;
  double tilt_y = 0.0;
  double gain = 1.0;
  double bias = 0.0;
  double noise_sigma = 2.0;
};

/// The 3x3 homography that maps a view pixel to a texture pixel.
inline cv::Matx33d viewToTexture(const ViewPose& pose, cv::Size size) {
  const double a = pose.angle_deg * M_PI / 180.0;
  const double c = std::cos(a) / pose.scale;
  const double s = std::sin(a) / pose.scale;
  const cv::Matx33d centre_view(1, 0, -size.width / 2.0, 0, 1, -size.height / 2.0, 0, 0, 1);
  const cv::Matx33d tilt(1, 0, 0, 0, 1, 0, pose.tilt_x, pose.tilt_y, 1);
  const cv::Matx33d rotate_scale(c, -s, pose.x, s, c, pose.y, 0, 0, 1);
  return rotate_scale * tilt * centre_view;
}

/// Renders a grey view of the texture; `seed` drives the pixel noise.
inline cv::Mat renderView(const cv::Mat& texture, const ViewPose& pose, std::uint32_t seed,
                          cv::Size size = cv::Size(640, 480)) {
  cv::Mat view;
  cv::warpPerspective(texture, view, cv::Mat(viewToTexture(pose, size)), size,
                      cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_REFLECT);
  cv::Mat noisy;
  view.convertTo(noisy, CV_32F, pose.gain, pose.bias);
  cv::Mat noise(size, CV_32F);
  cv::theRNG().state = seed + 1;
  cv::randn(noise, 0.0, pose.noise_sigma);
  noisy += noise;
  noisy.convertTo(view, CV_8U);
  return view;
}

/// The same view through a lens: pixel d of the result shows what the ideal pinhole camera with
/// the lens' fx, fy, cx, cy shows at the pixel its ray meets. `unproject` maps a pixel to its ray.
template <typename Unproject>
cv::Mat renderThroughLens(const cv::Mat& texture, const ViewPose& pose, double fx, double fy,
                          double cx, double cy, const Unproject& unproject,
                          cv::Size size = cv::Size(640, 480)) {
  const cv::Matx33d H = viewToTexture(pose, size);
  cv::Mat map_x(size, CV_32F);
  cv::Mat map_y(size, CV_32F);
  for (int v = 0; v < size.height; ++v) {
    for (int u = 0; u < size.width; ++u) {
      const auto ray = unproject(u, v);
      const cv::Vec3d pinhole(fx * ray[0] / ray[2] + cx, fy * ray[1] / ray[2] + cy, 1.0);
      const cv::Vec3d t = H * pinhole;
      map_x.at<float>(v, u) = static_cast<float>(t[0] / t[2]);
      map_y.at<float>(v, u) = static_cast<float>(t[1] / t[2]);
    }
  }
  cv::Mat view;
  cv::remap(texture, view, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_REFLECT);
  return view;
}

/// Pastes `patch` into `image` with its top-left corner at `corner` (the "same poster in two
/// places" of the repeated-texture tests).
inline void pastePoster(cv::Mat& image, const cv::Mat& patch, cv::Point corner) {
  patch.copyTo(image(cv::Rect(corner, patch.size())));
}

/// One keyframe of a synthetic walk: which wall (texture) it sees and from where.
struct SyntheticKeyframe {
  int wall = 0;
  ViewPose pose;
};

/// A sideways walk along a wall: views centred at x = x_begin, x_begin + step, ... < x_end, all
/// with `base`'s other settings.
inline std::vector<SyntheticKeyframe> walkAlong(int wall, double x_begin, double x_end, double step,
                                                ViewPose base) {
  std::vector<SyntheticKeyframe> walk;
  for (double x = x_begin; x < x_end; x += step) {
    base.x = x;
    walk.push_back(SyntheticKeyframe{wall, base});
  }
  return walk;
}

/// Ground truth: two views show the same place when they see the same wall with centres less
/// than half a view width (320 px) apart, i.e. they overlap by more than half.
inline bool samePlace(const SyntheticKeyframe& a, const SyntheticKeyframe& b) {
  return a.wall == b.wall && std::abs(a.pose.x - b.pose.x) < 320.0;
}

}  // namespace scale_drift_slam::loop::testing
