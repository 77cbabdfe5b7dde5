#include "scale_drift_slam/sim/drifting_pose_graph.h"

#include <cmath>
#include <random>
#include <stdexcept>
#include <string>

namespace scale_drift_slam::sim {
namespace {

using geometry::SE3;
using geometry::Sim3;

/// Camera on the circle at angle phi, looking outwards: z = radial direction, y = world y (down),
/// x = y cross z. Returns T_kf_world.
SE3 circlePose(double radius, double phi) {
  const Eigen::Vector3d z(std::cos(phi), 0.0, std::sin(phi));
  const Eigen::Vector3d y(0.0, 1.0, 0.0);
  Eigen::Matrix3d R_world_cam;
  R_world_cam << y.cross(z), y, z;
  const Eigen::Vector3d centre = radius * z;
  return SE3(R_world_cam, centre).inverse();
}

std::vector<std::pair<int, int>> loopPairs(const DriftingPoseGraphOptions& options) {
  const int per_lap = options.keyframes_per_lap;
  const int n = per_lap * options.laps;
  std::vector<std::pair<int, int>> pairs;
  if (options.laps == 1) {
    pairs.emplace_back(n - 1, 0);  // the last keyframe sees the first place again
    return pairs;
  }
  // Evenly spaced over laps 2.., each back to the same place in lap 1.
  const int candidates = n - per_lap;
  for (int k = 0; k < options.loops; ++k) {
    const int from =
        per_lap + static_cast<int>((static_cast<long>(k) * candidates) / options.loops);
    pairs.emplace_back(from, from % per_lap);
  }
  return pairs;
}

}  // namespace

void DriftingPoseGraphOptions::validate() const {
  auto fail = [](const std::string& what) {
    throw std::invalid_argument("drifting pose graph: " + what);
  };
  if (keyframes_per_lap < 3) {
    fail("keyframes_per_lap must be >= 3");
  }
  if (laps < 1) {
    fail("laps must be >= 1");
  }
  if (!(radius > 0.0) || !std::isfinite(radius)) {
    fail("radius must be finite and > 0");
  }
  if (loops < 0) {
    fail("loops must be >= 0");
  }
  if (laps == 1 && loops > 1) {
    fail("one lap closes at most one loop");
  }
  if (laps > 1 && loops > keyframes_per_lap * (laps - 1)) {
    fail("more loops than keyframes");
  }
  if (covisibility_neighbours < 0) {
    fail("covisibility_neighbours must be >= 0");
  }
  for (double v :
       {log_scale_drift_per_keyframe, log_scale_noise, rotation_noise, translation_noise}) {
    if (!std::isfinite(v)) {
      fail("drift and noise parameters must be finite");
    }
  }
  if (log_scale_noise < 0 || rotation_noise < 0 || translation_noise < 0) {
    fail("noise standard deviations must be >= 0");
  }
}

DriftingPoseGraph makeDriftingPoseGraph(const DriftingPoseGraphOptions& options) {
  options.validate();
  const int n = options.keyframes_per_lap * options.laps;
  std::mt19937 rng(options.seed);
  std::normal_distribution<double> normal;
  auto noise = [&](double sigma) { return sigma * normal(rng); };

  DriftingPoseGraph out;
  double log_scale = 0.0;
  for (int i = 0; i < n; ++i) {
    if (i > 0) {
      log_scale += options.log_scale_drift_per_keyframe + noise(options.log_scale_noise);
    }
    const SE3 T = circlePose(options.radius, 2.0 * M_PI * i / options.keyframes_per_lap);
    const Sim3 V =
        Sim3(Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero(), log_scale) * Sim3(T);
    out.T_kf_world_true.push_back(T);
    out.S_kf_world_true.push_back(V);
    out.centres_true.push_back(T.inverseTranslation());
    if (i == 0) {
      out.T_kf_world_estimate.push_back(T);
      continue;
    }
    SE3::Tangent n_i;
    n_i << noise(options.rotation_noise), noise(options.rotation_noise),
        noise(options.rotation_noise), noise(options.translation_noise),
        noise(options.translation_noise), noise(options.translation_noise);
    const SE3 M = SE3::exp(n_i) * loop::dropScale(V * out.S_kf_world_true[i - 1].inverse());
    out.T_kf_world_estimate.push_back(M * out.T_kf_world_estimate.back());
  }

  for (int i = 0; i < n; ++i) {
    out.graph.addVertex(i, Sim3(out.T_kf_world_estimate[i]), i == 0);
  }
  for (int i = 1; i < n; ++i) {
    for (int back = 1; back <= 1 + options.covisibility_neighbours && back <= i; ++back) {
      loop::PoseGraphEdge edge;
      edge.from = i;
      edge.to = i - back;
      edge.S_from_to =
          Sim3(out.T_kf_world_estimate[i] * out.T_kf_world_estimate[i - back].inverse());
      edge.kind = back == 1 ? loop::EdgeKind::kConsecutive : loop::EdgeKind::kCovisibility;
      out.graph.addEdge(edge);
    }
  }
  if (options.loops > 0) {
    for (const auto& [from, to] : loopPairs(options)) {
      loop::PoseGraphEdge edge;
      edge.from = from;
      edge.to = to;
      edge.S_from_to = out.S_kf_world_true[from] * out.S_kf_world_true[to].inverse();
      edge.kind = loop::EdgeKind::kLoop;
      out.graph.addEdge(edge);
    }
  }
  return out;
}

double centreRmse(const std::map<map::KeyframeId, geometry::Sim3>& S_kf_world,
                  const std::vector<Eigen::Vector3d>& centres_true) {
  if (S_kf_world.size() != centres_true.size()) {
    throw std::invalid_argument("centreRmse: " + std::to_string(S_kf_world.size()) + " poses but " +
                                std::to_string(centres_true.size()) + " centres");
  }
  double sum = 0.0;
  for (const auto& [id, S] : S_kf_world) {
    sum += (loop::cameraCentre(S) - centres_true.at(id)).squaredNorm();
  }
  return std::sqrt(sum / centres_true.size());
}

}  // namespace scale_drift_slam::sim
