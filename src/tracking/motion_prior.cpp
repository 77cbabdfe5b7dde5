#include "scale_drift_slam/tracking/motion_prior.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Cholesky>

namespace scale_drift_slam::tracking {

void MotionPriorParams::validate() const {
  flow.validate();
  if (!(flow_sigma_px > 0.0)) throw std::invalid_argument("motion_prior.flow_sigma_px must be > 0");
  if (min_tracks < 6) throw std::invalid_argument("motion_prior.min_tracks must be >= 6");
  if (max_tracks < min_tracks) {
    throw std::invalid_argument("motion_prior.max_tracks must be >= motion_prior.min_tracks");
  }
  for (const double v : {min_rotation_sigma, min_translation_sigma, fallback_rotation_sigma,
                         fallback_translation_sigma}) {
    if (!(v > 0.0)) throw std::invalid_argument("motion_prior sigmas must be > 0");
  }
  if (!std::isfinite(candidate_max_forward_backward_px)) {
    throw std::invalid_argument("motion_prior.candidate_max_forward_backward_px must be finite");
  }
  if (candidate_flow_window != 0 && (candidate_flow_window < 5 || candidate_flow_window % 2 == 0)) {
    throw std::invalid_argument("motion_prior.candidate_flow_window must be 0 or odd and >= 5");
  }
}

namespace {

int countInliers(const features::MotionOnlyResult& result) {
  return static_cast<int>(std::count(result.inlier.begin(), result.inlier.end(), true));
}

/// Where the constant-velocity motion moves a point: its pixel in the current camera, or the
/// pixel itself when that is not in the image.
cv::Point2f moved(const Eigen::Vector3d& p_cur, const cv::Point2f& px,
                  const geometry::CameraModel& camera) {
  const std::optional<Eigen::Vector2d> pixel = camera.project(p_cur);
  if (!pixel || !camera.isInImage(*pixel)) return px;
  return cv::Point2f(static_cast<float>(pixel->x()), static_cast<float>(pixel->y()));
}

/// The points at the scene depth in the previous camera (their own depth is unknown here), moved
/// into the camera `T_cur_world`: where their flow starts.
std::vector<cv::Point2f> movedAtSceneDepth(const std::vector<cv::Point2f>& px,
                                           const geometry::SE3& T_cur_world,
                                           const geometry::SE3& T_previous, double scene_depth,
                                           const geometry::CameraModel& camera) {
  const geometry::SE3 T_cur_previous = T_cur_world * T_previous.inverse();
  const double depth = scene_depth > 0.0 ? scene_depth : 1.0;
  std::vector<cv::Point2f> start;
  start.reserve(px.size());
  for (const cv::Point2f& p : px) {
    const Eigen::Vector3d ray = camera.unproject(Eigen::Vector2d(p.x, p.y));
    start.push_back(ray.z() > 0.0 ? moved(T_cur_previous * (ray * (depth / ray.z())), p, camera)
                                  : p);
  }
  return start;
}

OpticalFlowParams candidateFlowParams(const MotionPriorParams& params) {
  OpticalFlowParams flow = params.flow;
  if (params.candidate_flow_window > 0) flow.window = params.candidate_flow_window;
  return flow;
}

Eigen::Matrix<double, 6, 6> diagonalSigma(double rotation, double translation) {
  Eigen::Matrix<double, 6, 1> d;
  d << Eigen::Vector3d::Constant(rotation * rotation),
      Eigen::Vector3d::Constant(translation * translation);
  return d.asDiagonal();
}

}  // namespace

MotionPriorEstimator::MotionPriorEstimator(
    const MotionPriorParams& params, const features::MotionOnlyBundleAdjustmentParams& motion_ba)
    : params_(params),
      motion_ba_(motion_ba),
      flow_(params.flow),
      candidate_flow_(candidateFlowParams(params)) {
  params_.validate();
}

MotionPrior MotionPriorEstimator::fallback(const geometry::SE3& T_guess, double scene_depth) const {
  MotionPrior prior;
  prior.T_cur_world = T_guess;
  prior.Sigma = diagonalSigma(params_.fallback_rotation_sigma,
                              params_.fallback_translation_sigma * scene_depth);
  return prior;
}

MotionPrior MotionPriorEstimator::estimate(
    const features::ImagePyramid& previous, const features::ImagePyramid& current,
    const std::vector<FlowSeed>& seeds, const std::vector<cv::Point2f>& extra_px,
    const geometry::SE3& T_guess, const geometry::SE3& T_previous, double scene_depth,
    const geometry::CameraModel& camera, std::vector<cv::Point2f>* extra_tracked,
    std::vector<unsigned char>* extra_ok) {
  // An even subset of the seeds is plenty for six pose parameters and bounds the flow's cost.
  std::vector<FlowSeed> picked;
  const std::size_t n = std::min<std::size_t>(seeds.size(), params_.max_tracks);
  for (std::size_t k = 0; k < n; ++k)
    picked.push_back(seeds[k * seeds.size() / n]);
  std::vector<cv::Point2f> seed_from, seed_start;
  for (const FlowSeed& seed : picked) {
    seed_from.push_back(seed.px);
    seed_start.push_back(params_.predict_flow ? moved(T_guess * seed.p_world, seed.px, camera)
                                              : seed.px);
  }
  // The seeds first: the prior rests on them alone.
  std::vector<cv::Point2f> to;
  std::vector<unsigned char> ok;
  flow_.track(previous, current, seed_from, &to, &ok, params_.predict_flow ? &seed_start : nullptr);
  MotionPrior prior = priorFromTracks(picked, to, ok, T_guess, scene_depth, camera);
  // A weak prior (fewer inliers than half the seeds' tracks, or none) and the image's shift far
  // from where the flow started: the motion was not the expected one (a jerk, a low frame rate).
  // The seeds again from the shift; the pose with more inliers wins.
  const long seed_tracks = std::count(ok.begin(), ok.end(), 1);
  const bool weak = !prior.from_flow || 2 * prior.num_tracks < seed_tracks;
  const cv::Point2d shift =
      weak ? shiftAwayFrom(previous, current, seed_from, seed_start) : cv::Point2d();
  bool from_shift_won = false;
  if (shift != cv::Point2d(0.0, 0.0)) {
    const cv::Point2f by(static_cast<float>(shift.x), static_cast<float>(shift.y));
    std::vector<cv::Point2f> shifted;
    for (const cv::Point2f& px : seed_from)
      shifted.push_back(px + by);
    std::vector<cv::Point2f> shifted_to;
    std::vector<unsigned char> shifted_ok;
    flow_.track(previous, current, seed_from, &shifted_to, &shifted_ok, &shifted);
    const MotionPrior from_shift =
        priorFromTracks(picked, shifted_to, shifted_ok, T_guess, scene_depth, camera);
    from_shift_won = from_shift.num_tracks > prior.num_tracks;
    if (from_shift_won) prior = from_shift;
  }
  // Then the candidates, once, from where the prior's pose moves them at the scene depth. The
  // pose the seeds measured is closer than the constant-velocity guess whenever the motion
  // changed (a turn that slows, a low frame rate), and from a start out of reach Lucas-Kanade
  // can converge onto the wrong texture: the backward check drops such a track, and it is not
  // tried again from the point as a failed one is.
  std::vector<cv::Point2f> candidate_start;
  if (params_.predict_flow || from_shift_won) {
    candidate_start = movedAtSceneDepth(extra_px, prior.from_flow ? prior.T_cur_world : T_guess,
                                        T_previous, scene_depth, camera);
  }
  candidate_flow_.track(previous, current, extra_px, extra_tracked, extra_ok,
                        candidate_start.empty() ? nullptr : &candidate_start);
  if (params_.candidate_max_forward_backward_px > 0.0 &&
      !(params_.flow.method == FlowMethod::kLucasKanade &&
        params_.flow.max_forward_backward_px > 0.0)) {
    candidate_flow_.checkBackward(previous, current, extra_px, *extra_tracked, extra_ok,
                                  params_.candidate_max_forward_backward_px);
  }
  return prior;
}

cv::Point2d MotionPriorEstimator::shiftAwayFrom(const features::ImagePyramid& previous,
                                                const features::ImagePyramid& current,
                                                const std::vector<cv::Point2f>& from,
                                                const std::vector<cv::Point2f>& start) {
  if (params_.flow.shift_retry_px <= 0.0 || params_.flow.method != FlowMethod::kLucasKanade ||
      from.empty()) {
    return {0.0, 0.0};
  }
  std::vector<float> dx, dy;
  for (std::size_t i = 0; i < from.size(); ++i) {
    dx.push_back(start[i].x - from[i].x);
    dy.push_back(start[i].y - from[i].y);
  }
  std::nth_element(dx.begin(), dx.begin() + dx.size() / 2, dx.end());
  std::nth_element(dy.begin(), dy.begin() + dy.size() / 2, dy.end());
  const cv::Point2d started(dx[dx.size() / 2], dy[dy.size() / 2]);
  const cv::Point2d shift = imageShift(previous, current, &shift_window_);
  const cv::Point2d off = shift - started;
  const double far = params_.flow.shift_retry_px;
  return off.dot(off) > far * far ? shift : cv::Point2d(0.0, 0.0);
}

MotionPrior MotionPriorEstimator::priorFromTracks(const std::vector<FlowSeed>& picked,
                                                  const std::vector<cv::Point2f>& to,
                                                  const std::vector<unsigned char>& ok,
                                                  const geometry::SE3& T_guess, double scene_depth,
                                                  const geometry::CameraModel& camera) const {
  features::MotionOnlyInput input;
  input.T_cam_world_guess = T_guess;
  input.focal_length_px = camera.calibration().meanFocalLength();
  for (std::size_t i = 0; i < picked.size(); ++i) {
    if (!ok[i]) continue;
    input.observations.push_back(
        {picked[i].p_world, camera.undistortToNormalized(Eigen::Vector2d(to[i].x, to[i].y))});
  }
  if (static_cast<int>(input.observations.size()) < params_.min_tracks) {
    return fallback(T_guess, scene_depth);
  }
  features::MotionOnlyResult result;
  int inliers = 0;
  try {
    result = features::solveMotionOnlyBundleAdjustment(input, motion_ba_);
    inliers = countInliers(result);
  } catch (const std::invalid_argument&) {  // the guess puts the points behind the camera
  }
  // Two thirds of the tracks refused: the BA may have started too far from the pose to reach it
  // (a turn that slowed between frames a second apart: the guess 7 degrees off, the tracks found
  // from the points themselves). The pose from the tracks alone, refined on its inliers.
  if (3 * inliers < static_cast<int>(input.observations.size())) {
    std::vector<int> kept;
    std::optional<features::MotionOnlyResult> from_tracks = features::solvePoseWithoutGuess(
        input, {motion_ba_.inlier_threshold_px, 50, 0.99, features::PnpSampleSolver::kP3P},
        motion_ba_, &kept);
    if (from_tracks && countInliers(*from_tracks) > inliers) {
      result = std::move(*from_tracks);
      inliers = countInliers(result);
    }
  }
  if (inliers < params_.min_tracks) return fallback(T_guess, scene_depth);
  MotionPrior prior;
  prior.T_cur_world = result.T_cam_world;
  prior.from_flow = true;
  prior.num_tracks = inliers;
  // Sigma_Delta = sigma_flow^2 (J^T J)^-1, floored: the flow error is not the only error.
  const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(result.information);
  const Eigen::Matrix<double, 6, 6> Sigma =
      ldlt.info() == Eigen::Success
          ? Eigen::Matrix<double, 6, 6>(ldlt.solve(Eigen::Matrix<double, 6, 6>::Identity()))
          : Eigen::Matrix<double, 6, 6>(Eigen::Matrix<double, 6, 6>::Zero());
  prior.Sigma =
      Sigma * params_.flow_sigma_px * params_.flow_sigma_px +
      diagonalSigma(params_.min_rotation_sigma, params_.min_translation_sigma * scene_depth);
  if (!prior.Sigma.allFinite()) return fallback(T_guess, scene_depth);
  return prior;
}

std::optional<MotionPriorEstimator::Carried> MotionPriorEstimator::carry(
    const std::vector<features::ImagePyramid>& frames, const std::vector<FlowSeed>& seeds,
    const geometry::SE3& T_guess, const geometry::CameraModel& camera) {
  Carried carried;
  carried.T_cam_world = T_guess;
  for (std::size_t i = 0; i < seeds.size(); ++i) {
    carried.seed.push_back(i);
    carried.px.push_back(seeds[i].px);
  }
  for (std::size_t f = 1; f < frames.size() && !carried.px.empty(); ++f) {
    std::vector<cv::Point2f> to;
    std::vector<unsigned char> ok;
    flow_.track(frames[f - 1], frames[f], carried.px, &to, &ok);
    std::size_t kept = 0;
    for (std::size_t i = 0; i < to.size(); ++i) {
      if (!ok[i]) continue;
      carried.seed[kept] = carried.seed[i];
      carried.px[kept++] = to[i];
    }
    carried.seed.resize(kept);
    carried.px.resize(kept);
  }
  if (static_cast<int>(carried.px.size()) < params_.min_tracks) return std::nullopt;
  if (frames.size() <= 1) return carried;
  features::MotionOnlyInput input;
  input.T_cam_world_guess = T_guess;
  input.focal_length_px = camera.calibration().meanFocalLength();
  for (std::size_t i = 0; i < carried.px.size(); ++i) {
    input.observations.push_back(
        {seeds[carried.seed[i]].p_world,
         camera.undistortToNormalized(Eigen::Vector2d(carried.px[i].x, carried.px[i].y))});
  }
  features::MotionOnlyResult result;
  try {
    result = features::solveMotionOnlyBundleAdjustment(input, motion_ba_);
  } catch (const std::invalid_argument&) {  // e.g. too few points in front of the camera
    return std::nullopt;
  }
  Carried inliers;
  inliers.T_cam_world = result.T_cam_world;
  for (std::size_t i = 0; i < carried.px.size(); ++i) {
    if (!result.inlier[i]) continue;
    inliers.seed.push_back(carried.seed[i]);
    inliers.px.push_back(carried.px[i]);
  }
  if (static_cast<int>(inliers.px.size()) < params_.min_tracks) return std::nullopt;
  return inliers;
}

}  // namespace scale_drift_slam::tracking
