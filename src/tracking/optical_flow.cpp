#include "scale_drift_slam/tracking/optical_flow.h"

#include <algorithm>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

namespace scale_drift_slam::tracking {

FlowMethod parseFlowMethod(const std::string& name) {
  if (name == "lucas_kanade" || name == "lk") return FlowMethod::kLucasKanade;
  if (name == "dis") return FlowMethod::kDis;
  throw std::invalid_argument("unknown optical flow method '" + name +
                              "' (accepted: lucas_kanade, dis)");
}

std::string flowMethodName(FlowMethod method) {
  return method == FlowMethod::kDis ? "dis" : "lucas_kanade";
}

void OpticalFlowParams::validate() const {
  if (window < 5 || window % 2 == 0) {
    throw std::invalid_argument("flow.window must be odd and >= 5");
  }
  if (pyramid_levels < 1 || pyramid_levels > 8) {
    throw std::invalid_argument("flow.pyramid_levels must be in [1, 8]");
  }
  if (max_iterations < 1) throw std::invalid_argument("flow.max_iterations must be >= 1");
  if (!(min_step_px > 0.0 && min_step_px < 1.0)) {
    throw std::invalid_argument("flow.min_step_px must be in (0, 1)");
  }
  if (!(max_error > 0.0)) throw std::invalid_argument("flow.max_error must be > 0");
  if (dis_preset < 0 || dis_preset > 2)
    throw std::invalid_argument("flow.dis_preset must be 0, 1 or 2");
  if (photometric_radius < 0 || photometric_radius > 50)
    throw std::invalid_argument("flow.photometric_radius must be in [0, 50]");
  if (!(shift_retry_px >= 0.0)) throw std::invalid_argument("flow.shift_retry_px must be >= 0");
}

cv::Point2d imageShift(const features::ImagePyramid& previous,
                       const features::ImagePyramid& current, cv::Mat* window) {
  // The finest level at most 160 px wide (VGA: 80x60, KITTI: 153x46, 240x180: 120x90): ~0.2 ms
  // a frame, past the parallax, and within a few pixels, well inside Lucas-Kanade's reach.
  const int levels = std::min(previous.numLevels(), current.numLevels());
  if (levels == 0 || previous.base().size() != current.base().size()) return {0.0, 0.0};
  int level = 0;
  while (level + 1 < levels && previous.levels[level].cols > 160)
    ++level;
  cv::Mat a, b;
  previous.levels[level].convertTo(a, CV_32F);
  current.levels[level].convertTo(b, CV_32F);
  if (window->size() != a.size()) cv::createHanningWindow(*window, a.size(), CV_32F);
  const double scale = static_cast<double>(previous.base().cols) / a.cols;
  return cv::phaseCorrelate(a, b, *window) * scale;
}

OpticalFlow::OpticalFlow(const OpticalFlowParams& params) : params_(params) {
  params_.validate();
  if (params_.method == FlowMethod::kDis) dis_ = cv::DISOpticalFlow::create(params_.dis_preset);
}

void OpticalFlow::track(const features::ImagePyramid& previous,
                        const features::ImagePyramid& current, const std::vector<cv::Point2f>& from,
                        std::vector<cv::Point2f>* to, std::vector<unsigned char>* ok,
                        const std::vector<cv::Point2f>* start) {
  if (start && start->size() != from.size()) {
    throw std::invalid_argument("optical flow: start positions do not match the points");
  }
  to->assign(from.size(), cv::Point2f(0.f, 0.f));
  ok->assign(from.size(), 0);
  if (from.empty() || previous.levels.empty() || current.levels.empty()) return;
  if (previous.base().size() != current.base().size()) return;
  if (params_.method == FlowMethod::kDis) {
    trackDis(previous, current, from, to, ok);
  } else {
    trackLucasKanade(previous, current, from, start, to, ok);
  }
  const cv::Size size = current.base().size();
  for (std::size_t i = 0; i < from.size(); ++i) {
    const cv::Point2f& p = (*to)[i];
    if (!(p.x >= 0.f && p.y >= 0.f && p.x <= size.width - 1.f && p.y <= size.height - 1.f)) {
      (*ok)[i] = 0;
    }
  }
}

void OpticalFlow::trackLucasKanade(const features::ImagePyramid& previous,
                                   const features::ImagePyramid& current,
                                   const std::vector<cv::Point2f>& from,
                                   const std::vector<cv::Point2f>* start,
                                   std::vector<cv::Point2f>* to,
                                   std::vector<unsigned char>* ok) const {
  const int levels = std::min({params_.pyramid_levels, previous.numLevels(), current.numLevels()});
  const std::vector<cv::Mat> prev_levels = previous.lucasKanadePyramid(levels);
  const std::vector<cv::Mat> cur_levels = current.lucasKanadePyramid(levels);
  if (start) *to = *start;
  lucasKanadePass(prev_levels, cur_levels, levels, from, start != nullptr, to, ok);
  if (start) {
    // A prediction can be wrong (the motion changed): where it moved a point and the flow
    // failed from there, try again from the point itself.
    std::vector<std::size_t> retry;
    std::vector<cv::Point2f> retry_from;
    for (std::size_t i = 0; i < from.size(); ++i) {
      const cv::Point2f moved = (*start)[i] - from[i];
      if (!(*ok)[i] && moved.dot(moved) > 1.0f) {
        retry.push_back(i);
        retry_from.push_back(from[i]);
      }
    }
    if (!retry.empty()) {
      std::vector<cv::Point2f> retry_to;
      std::vector<unsigned char> retry_ok;
      lucasKanadePass(prev_levels, cur_levels, levels, retry_from, false, &retry_to, &retry_ok);
      for (std::size_t k = 0; k < retry.size(); ++k) {
        (*to)[retry[k]] = retry_to[k];
        (*ok)[retry[k]] = retry_ok[k];
      }
    }
  }
}

void OpticalFlow::lucasKanadePass(const std::vector<cv::Mat>& previous,
                                  const std::vector<cv::Mat>& current, int levels,
                                  const std::vector<cv::Point2f>& from, bool from_start,
                                  std::vector<cv::Point2f>* to,
                                  std::vector<unsigned char>* ok) const {
  if (from.empty()) return;
  const int max_level = levels - 1;
  const cv::TermCriteria criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS,
                                  params_.max_iterations, params_.min_step_px);
  const cv::Size window(params_.window, params_.window);
  std::vector<float> error;
  cv::calcOpticalFlowPyrLK(previous, current, from, *to, *ok, error, window, max_level, criteria,
                           from_start ? cv::OPTFLOW_USE_INITIAL_FLOW : 0);
  for (std::size_t i = 0; i < from.size(); ++i) {
    if (error[i] > params_.max_error) (*ok)[i] = 0;
  }
  if (params_.max_forward_backward_px <= 0.0) return;
  dropBackwardMisses(previous, current, levels, from, *to, ok, params_.max_forward_backward_px);
}

void OpticalFlow::checkBackward(const features::ImagePyramid& previous,
                                const features::ImagePyramid& current,
                                const std::vector<cv::Point2f>& from,
                                const std::vector<cv::Point2f>& to, std::vector<unsigned char>* ok,
                                double max_px) const {
  const int levels = std::min({params_.pyramid_levels, previous.numLevels(), current.numLevels()});
  dropBackwardMisses(previous.lucasKanadePyramid(levels), current.lucasKanadePyramid(levels),
                     levels, from, to, ok, max_px);
}

void OpticalFlow::dropBackwardMisses(const std::vector<cv::Mat>& previous,
                                     const std::vector<cv::Mat>& current, int levels,
                                     const std::vector<cv::Point2f>& from,
                                     const std::vector<cv::Point2f>& to,
                                     std::vector<unsigned char>* ok, double max_px) const {
  // Only the tracks still standing are followed back (a lost track's end is no position), each
  // starting where it came from.
  std::vector<std::size_t> standing;
  std::vector<cv::Point2f> ends, back;
  for (std::size_t i = 0; i < from.size(); ++i) {
    if (!(*ok)[i]) continue;
    standing.push_back(i);
    ends.push_back(to[i]);
    back.push_back(from[i]);
  }
  if (standing.empty()) return;
  std::vector<unsigned char> back_ok;
  std::vector<float> error;
  cv::calcOpticalFlowPyrLK(current, previous, ends, back, back_ok, error,
                           cv::Size(params_.window, params_.window), levels - 1,
                           cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS,
                                            params_.max_iterations, params_.min_step_px),
                           cv::OPTFLOW_USE_INITIAL_FLOW);
  for (std::size_t k = 0; k < standing.size(); ++k) {
    const cv::Point2f d = back[k] - from[standing[k]];
    if (!back_ok[k] || d.dot(d) > max_px * max_px) (*ok)[standing[k]] = 0;
  }
}

void OpticalFlow::trackDis(const features::ImagePyramid& previous,
                           const features::ImagePyramid& current,
                           const std::vector<cv::Point2f>& from, std::vector<cv::Point2f>* to,
                           std::vector<unsigned char>* ok) {
  // DIS wants continuous images: copy the ROIs out of their padded buffers.
  dis_->calc(previous.base().clone(), current.base().clone(), flow_);
  for (std::size_t i = 0; i < from.size(); ++i) {
    const int x = cvRound(from[i].x), y = cvRound(from[i].y);
    if (x < 0 || y < 0 || x >= flow_.cols || y >= flow_.rows) continue;
    const cv::Vec2f f = flow_.at<cv::Vec2f>(y, x);
    (*to)[i] = from[i] + cv::Point2f(f[0], f[1]);
    (*ok)[i] = 1;
  }
}

}  // namespace scale_drift_slam::tracking
