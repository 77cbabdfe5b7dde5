// Structure-only BA on simulated cameras and points with known truth: exact recovery from
// noise-free observations, noise-level accuracy with Gaussian noise, robustness to gross
// outliers through the pseudo-Huber kernel, the map adapter, and refusal of bad input.

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "scale_drift_slam/mapping/structure_only_ba.h"

namespace scale_drift_slam::mapping {
namespace {

using geometry::SE3;

constexpr double kFocal = 400.0;

/// Ten cameras on an arc looking at points spread in a 4 m cube around the origin, each point
/// seen by every camera; observations with pixel noise and a share of gross outliers.
struct Scene {
  std::vector<Eigen::Vector3d> truth;
  StructureOnlyProblem problem;
};

Scene makeScene(int num_points, double noise_px, double outlier_share, double start_offset,
                std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> uniform(-2.0, 2.0), unit(0.0, 1.0);
  Scene scene;
  for (int c = 0; c < 10; ++c) {
    const double phi = -0.6 + 0.12 * c;
    const Eigen::Vector3d centre(10 * std::sin(phi), 0.3 * c - 1.0, -10 * std::cos(phi));
    const Eigen::Vector3d z = -centre.normalized();
    const Eigen::Vector3d x = Eigen::Vector3d::UnitY().cross(z).normalized();
    Eigen::Matrix3d R_world_cam;
    R_world_cam << x, z.cross(x), z;
    scene.problem.T_cam_world.push_back(SE3(R_world_cam, centre).inverse());
  }
  scene.problem.first_observation.push_back(0);
  for (int i = 0; i < num_points; ++i) {
    const Eigen::Vector3d p(uniform(rng), uniform(rng), uniform(rng));
    scene.truth.push_back(p);
    scene.problem.points.push_back(p + start_offset *
                                           Eigen::Vector3d(normal(rng), normal(rng), normal(rng)));
    for (std::size_t c = 0; c < scene.problem.T_cam_world.size(); ++c) {
      const Eigen::Vector3d p_cam = scene.problem.T_cam_world[c] * p;
      Eigen::Vector2d xy = p_cam.head<2>() / p_cam.z();
      xy += noise_px / kFocal * Eigen::Vector2d(normal(rng), normal(rng));
      if (unit(rng) < outlier_share) {
        xy += 30.0 / kFocal * Eigen::Vector2d(1.0, -1.0);
      }
      scene.problem.observations.push_back({c, xy});
    }
    scene.problem.first_observation.push_back(scene.problem.observations.size());
  }
  return scene;
}

double pointRmse(const Scene& scene) {
  double sum = 0.0;
  for (std::size_t i = 0; i < scene.truth.size(); ++i) {
    sum += (scene.problem.points[i] - scene.truth[i]).squaredNorm();
  }
  return std::sqrt(sum / scene.truth.size());
}

TEST(StructureOnlyBA, RecoversExactPointsFromExactObservations) {
  for (bool robust : {true, false}) {
    Scene scene = makeScene(200, 0.0, 0.0, 0.3, 1);
    StructureOnlyBAOptions options;
    options.robust = robust;
    options.max_iterations = 30;
    const StructureOnlyBAResult result =
        refineStructure(scene.problem, Eigen::Vector2d(kFocal, -kFocal), options);
    EXPECT_LT(pointRmse(scene), 1e-8) << robust;
    EXPECT_LT(result.after.rms, 1e-6);
    EXPECT_GT(result.before.rms, 1.0);
    EXPECT_EQ(result.points, 200u);
    EXPECT_EQ(result.observations, 2000u);
    EXPECT_LT(result.final_cost, 1e-10 * result.initial_cost);
  }
}

TEST(StructureOnlyBA, NoisyObservationsGiveNoiseLevelErrors) {
  Scene scene = makeScene(500, 0.5, 0.0, 0.3, 2);
  const StructureOnlyBAResult result =
      refineStructure(scene.problem, Eigen::Vector2d(kFocal, kFocal), StructureOnlyBAOptions());
  // 0.5 px on a 400 px focal length at 10 m, ten views over 70 degrees: about 1 cm; allow 2 cm.
  EXPECT_LT(pointRmse(scene), 0.02);
  // The rms of the 2D residual (0.5 px per axis) of a least-squares fit that uses 3 of the 20
  // degrees of freedom of each point: 0.5 sqrt(2) sqrt(17/20) = 0.65 px.
  EXPECT_NEAR(result.after.rms, 0.5 * std::sqrt(2.0 * 17.0 / 20.0), 0.05);
  EXPECT_LE(result.max_iterations_used, 10);
}

TEST(StructureOnlyBA, PseudoHuberResistsOutliers) {
  StructureOnlyBAOptions robust, plain;
  plain.robust = false;
  // 15 % of the observations are 30 px off, all in the same direction (a biased contamination).
  Scene a = makeScene(300, 0.5, 0.15, 0.3, 3), b = a;
  const StructureOnlyBAResult with_kernel =
      refineStructure(a.problem, Eigen::Vector2d(kFocal, kFocal), robust);
  const StructureOnlyBAResult without_kernel =
      refineStructure(b.problem, Eigen::Vector2d(kFocal, kFocal), plain);
  // Measured: 5.7 cm with the kernel, 28 cm without.
  EXPECT_LT(pointRmse(a), 0.3 * pointRmse(b));
  EXPECT_LT(pointRmse(a), 0.08);
  // The kernel fits the inliers (median error near the noise), least squares spreads the bias.
  EXPECT_LT(with_kernel.after.median, 1.0);
  EXPECT_GT(without_kernel.after.median, 3.0);
}

TEST(StructureOnlyBA, SkipsPointsItCannotDetermine) {
  Scene scene = makeScene(3, 0.0, 0.0, 0.3, 4);
  // Point 1 keeps one observation only: its depth is unobservable.
  scene.problem.observations.erase(scene.problem.observations.begin() + 11,
                                   scene.problem.observations.begin() + 20);
  scene.problem.first_observation = {0, 10, 11, 21};
  const Eigen::Vector3d before = scene.problem.points[1];
  const StructureOnlyBAResult result =
      refineStructure(scene.problem, Eigen::Vector2d(kFocal, kFocal), StructureOnlyBAOptions());
  EXPECT_EQ(result.points, 2u);
  EXPECT_EQ(result.points_skipped, 1u);
  EXPECT_EQ(scene.problem.points[1], before);
}

TEST(StructureOnlyBA, MapAdapterRefinesTheListedPoints) {
  Scene scene = makeScene(20, 0.0, 0.0, 0.2, 5);
  map::Map m;
  for (std::size_t i = 0; i < scene.truth.size(); ++i) {
    m.addPoint({static_cast<map::PointId>(100 + i), scene.problem.points[i], 0, {}});
  }
  for (std::size_t c = 0; c < scene.problem.T_cam_world.size(); ++c) {
    map::Keyframe keyframe;
    keyframe.id = static_cast<map::KeyframeId>(c * 3);
    keyframe.T_kf_world = scene.problem.T_cam_world[c];
    for (std::size_t i = 0; i < scene.truth.size(); ++i) {
      keyframe.observations.push_back(
          {static_cast<map::PointId>(100 + i), scene.problem.observations[10 * i + c].xy});
    }
    m.addKeyframe(keyframe);
  }
  const Eigen::Vector3d untouched = m.point(101).p_world;
  const auto version = m.version();
  const StructureOnlyBAResult result =
      refineStructure(m, {100, 102}, Eigen::Vector2d(kFocal, kFocal), StructureOnlyBAOptions());
  EXPECT_EQ(result.points, 2u);
  EXPECT_EQ(result.observations, 20u);
  // Noise-free, but the map holds its observations in single precision (1e-7 relative).
  EXPECT_LT((m.point(100).p_world - scene.truth[0]).norm(), 1e-6);
  EXPECT_LT((m.point(102).p_world - scene.truth[2]).norm(), 1e-6);
  EXPECT_EQ(m.point(101).p_world, untouched);
  EXPECT_GT(m.version(), version);
  refineStructure(m, {}, Eigen::Vector2d(kFocal, kFocal), StructureOnlyBAOptions());
  EXPECT_LT(reprojectionStats(m, Eigen::Vector2d(kFocal, kFocal)).rms, 1e-5);
}

TEST(StructureOnlyBA, RefusesBadInput) {
  Scene scene = makeScene(5, 0.0, 0.0, 0.2, 6);
  const Eigen::Vector2d focal(kFocal, kFocal);
  StructureOnlyBAOptions options;
  options.huber_width_px = 0.0;
  EXPECT_THROW(refineStructure(scene.problem, focal, options), std::invalid_argument);
  options = StructureOnlyBAOptions();
  options.max_iterations = 0;
  EXPECT_THROW(refineStructure(scene.problem, focal, options), std::invalid_argument);
  EXPECT_THROW(refineStructure(scene.problem, Eigen::Vector2d(0.0, 1.0), StructureOnlyBAOptions()),
               std::invalid_argument);
  Scene broken = scene;
  broken.problem.observations[3].pose = 99;
  EXPECT_THROW(refineStructure(broken.problem, focal, StructureOnlyBAOptions()),
               std::invalid_argument);
  broken = scene;
  broken.problem.first_observation.pop_back();
  EXPECT_THROW(refineStructure(broken.problem, focal, StructureOnlyBAOptions()),
               std::invalid_argument);
  broken = scene;
  broken.problem.points[2].x() = std::nan("");
  EXPECT_THROW(refineStructure(broken.problem, focal, StructureOnlyBAOptions()),
               std::invalid_argument);
  map::Map m;
  EXPECT_THROW(refineStructure(m, {7}, focal, StructureOnlyBAOptions()), std::out_of_range);
}

}  // namespace
}  // namespace scale_drift_slam::mapping
