// Back-end timings (doc/benchmarks.md, "Back-end"): the sliding-window BA at the size of the
// issue (10 keyframes, 1500 points, ~10000 observations), motion-only BA with 300 points (both
// solvers). The paper's simulations (a full circle run and a sphere run): bench_simulation.cpp.

#include <cstdio>
#include <random>

#include "bench_report.h"
#include "scale_drift_slam/features/motion_only_bundle_adjustment.h"
#include "scale_drift_slam/mapping/window_bundle_adjustment.h"

namespace sds = scale_drift_slam;
using sds::geometry::SE3;

namespace {

SE3 perturbed(const SE3& T, double rotation, double translation, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  SE3::Tangent xi;
  xi << rotation * n(rng), rotation * n(rng), rotation * n(rng), translation * n(rng),
      translation * n(rng), translation * n(rng);
  return SE3::exp(xi) * T;
}

/// 10 keyframes 0.2 m apart looking along z at 1500 points 4..8 m ahead; each point seen by the
/// keyframes whose field of view holds it (~6.7 on average); 1 px noise at f = 400.
/// `settled` stands in for the state after a new keyframe joins: the older keyframes and points
/// near the truth (0.2 mrad, 2 mm), the newest keyframe off by 2 cm and the points only the two
/// newest see by 5 cm. Otherwise every free pose is off by ~1 cm and every point by ~3 cm (a cold
/// start).
sds::mapping::WindowBundleInput makeWindow(std::mt19937& rng, bool settled) {
  constexpr double kFocal = 400.0;
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, 1.0 / kFocal);
  sds::mapping::WindowBundleInput input;
  input.focal_length_px = kFocal;
  std::vector<SE3> truth;
  for (int i = 0; i < 10; ++i) {
    truth.emplace_back(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-0.2 * i, 0.0, 0.0));
    input.keyframes.push_back({static_cast<sds::map::KeyframeId>(i),
                               i < 2      ? truth.back()
                               : !settled ? perturbed(truth.back(), 0.002, 0.01, rng)
                               : i == 9   ? perturbed(truth.back(), 0.002, 0.02, rng)
                                          : perturbed(truth.back(), 0.0002, 0.002, rng),
                               i < 2});
  }
  while (input.points.size() < 1500) {
    const Eigen::Vector3d p(0.9 + 4.0 * u(rng), 2.0 * u(rng), 6.0 + 2.0 * u(rng));
    std::vector<sds::mapping::BundleObservation> seen;
    for (std::size_t k = 0; k < truth.size(); ++k) {
      const Eigen::Vector3d y = truth[k] * p;
      const Eigen::Vector2d xy = y.head<2>() / y.z();
      if (std::abs(xy.x()) > 0.3 || std::abs(xy.y()) > 0.4) continue;
      seen.push_back({k, input.points.size(), xy + Eigen::Vector2d(noise(rng), noise(rng))});
    }
    if (seen.size() < 2) continue;
    const bool is_new = seen.front().keyframe_index >= 8;
    const double offset = !settled ? 0.03 : is_new ? 0.05 : 0.002;
    input.points.push_back({static_cast<sds::map::PointId>(input.points.size()),
                            p + offset * Eigen::Vector3d(u(rng), u(rng), u(rng)), false});
    input.observations.insert(input.observations.end(), seen.begin(), seen.end());
  }
  return input;
}

sds::features::MotionOnlyInput makeMotionOnly(std::mt19937& rng, int num_points) {
  constexpr double kFocal = 400.0;
  std::uniform_real_distribution<double> u(-1.0, 1.0), unit(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 1.0 / kFocal);
  sds::features::MotionOnlyInput input;
  input.focal_length_px = kFocal;
  const SE3 T_true(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.1, 0.2, 0.3));
  for (int i = 0; i < num_points; ++i) {
    const double depth = 2.0 + 6.0 * unit(rng);
    const Eigen::Vector3d p_cam(0.6 * u(rng) * depth, 0.45 * u(rng) * depth, depth);
    input.observations.push_back(
        {T_true.inverse() * p_cam,
         p_cam.head<2>() / depth + Eigen::Vector2d(noise(rng), noise(rng))});
  }
  input.T_cam_world_guess = perturbed(T_true, 0.01, 0.03, rng);
  return input;
}

}  // namespace

int main(int argc, char** argv) {
  sds::bench::Report report("backend", argc, argv);
  std::mt19937 rng(5);

  for (bool settled : {true, false}) {
    const sds::mapping::WindowBundleInput window = makeWindow(rng, settled);
    const std::string name = settled ? "new keyframe joins" : "cold start";
    const sds::mapping::WindowBundleAdjustmentParams window_params;
    sds::mapping::WindowBundleResult window_result;
    report.timeMs(
        "window BA (" + name + "): 10 keyframes, 1500 points, " +
            std::to_string(window.observations.size()) + " observations",
        15,
        [&] { window_result = sds::mapping::solveWindowBundleAdjustment(window, window_params); });
    report.add("window BA (" + name + "): iterations", window_result.statistics.iterations, "");
    report.add("window BA (" + name + "): final RMSE", window_result.statistics.final_rmse_px,
               "px");
  }

  for (auto solver :
       {sds::features::MotionOnlySolver::kHandWritten, sds::features::MotionOnlySolver::kCeres}) {
    const sds::features::MotionOnlyInput input = makeMotionOnly(rng, 300);
    sds::features::MotionOnlyBundleAdjustmentParams params;
    params.solver = solver;
    const std::string name =
        solver == sds::features::MotionOnlySolver::kCeres ? "Ceres" : "hand-written LM";
    sds::features::MotionOnlyResult result;
    report.timeMs("motion-only BA, 300 points, " + name, 200,
                  [&] { result = sds::features::solveMotionOnlyBundleAdjustment(input, params); });
    report.add("motion-only BA, " + name + ": iterations", result.statistics.iterations, "");
  }
  return 0;
}
