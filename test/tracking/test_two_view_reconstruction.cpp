// Two-view initialisation on synthetic correspondences with a known answer: a general 3D scene
// (the essential matrix is chosen), a planar scene (the homography is chosen), both recover the
// motion and the structure up to the scale, normalised to median depth 1; pure rotation and too
// little baseline are refused with a reason.

#include <random>

#include <gtest/gtest.h>

#include "scale_drift_slam/geometry/so3.h"
#include "scale_drift_slam/tracking/two_view_reconstruction.h"

namespace scale_drift_slam::tracking {
namespace {

constexpr double kFocal = 500.0;

struct Scene {
  std::vector<Eigen::Vector3d> points;  // first camera frame
  std::vector<Eigen::Vector2d> xy_first, xy_second;
};

Scene observe(const std::vector<Eigen::Vector3d>& points, const geometry::SE3& T_second_first,
              double noise_px, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_px / kFocal);
  Scene s;
  for (const auto& p : points) {
    const Eigen::Vector3d q = T_second_first * p;
    const Eigen::Vector2d a = p.hnormalized(), b = q.hnormalized();
    // Keep what a 640x480 camera with f = 500 would see.
    if (q.z() <= 0 || a.cwiseAbs().maxCoeff() > 0.6 || b.cwiseAbs().maxCoeff() > 0.6) continue;
    s.points.push_back(p);
    s.xy_first.push_back(a + Eigen::Vector2d(noise(rng), noise(rng)));
    s.xy_second.push_back(b + Eigen::Vector2d(noise(rng), noise(rng)));
  }
  return s;
}

std::vector<Eigen::Vector3d> randomBox(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> xy(-2.0, 2.0), z(3.0, 7.0);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < n; ++i)
    points.emplace_back(xy(rng), xy(rng), z(rng));
  return points;
}

std::vector<Eigen::Vector3d> randomPlane(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> xy(-2.0, 2.0);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < n; ++i) {
    const double x = xy(rng), y = xy(rng);
    points.emplace_back(x, y, 4.0 + 0.4 * x - 0.2 * y);  // a tilted wall
  }
  return points;
}

double rotationErrorDeg(const geometry::SE3& a, const geometry::SE3& b) {
  return geometry::logSO3(a.rotation() * b.rotation().conjugate()).norm() * 180.0 / M_PI;
}

void expectRecovers(const Scene& scene, const geometry::SE3& truth, const TwoViewResult& r) {
  ASSERT_TRUE(r.success) << r.reason;
  EXPECT_LT(rotationErrorDeg(r.T_second_first, truth), 0.5);
  const double direction_error =
      std::acos(r.T_second_first.translation().normalized().dot(truth.translation().normalized()));
  EXPECT_LT(direction_error * 180.0 / M_PI, 3.0);
  // Structure equals the truth scaled to median depth 1.
  std::vector<double> depths;
  for (const auto& p : scene.points)
    depths.push_back(p.z());
  std::nth_element(depths.begin(), depths.begin() + depths.size() / 2, depths.end());
  const double scale = 1.0 / depths[depths.size() / 2];
  EXPECT_GT(r.num_triangulated, static_cast<int>(0.75 * scene.points.size()));
  std::vector<double> errors;
  for (std::size_t i = 0; i < scene.points.size(); ++i) {
    if (r.triangulated[i]) errors.push_back((r.points_first[i] - scene.points[i] * scale).norm());
  }
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  EXPECT_LT(errors[errors.size() / 2], 0.03);  // 3% of the median depth
  EXPECT_NEAR(r.T_second_first.translation().norm(), truth.translation().norm() * scale, 0.02);
}

TEST(TwoViewReconstruction, GeneralSceneUsesTheEssentialMatrix) {
  const geometry::SE3 truth(geometry::expSO3(Eigen::Vector3d(0.02, -0.08, 0.01)),
                            Eigen::Vector3d(0.5, 0.05, 0.1));
  const Scene scene = observe(randomBox(300, 1), truth, 0.7, 2);
  const TwoViewResult r = reconstructTwoView(scene.xy_first, scene.xy_second, kFocal, {});
  EXPECT_FALSE(r.used_homography) << r.gric_homography << " vs " << r.gric_essential;
  expectRecovers(scene, truth, r);
}

TEST(TwoViewReconstruction, PlanarSceneUsesTheHomography) {
  const geometry::SE3 truth(geometry::expSO3(Eigen::Vector3d(-0.03, 0.1, 0.02)),
                            Eigen::Vector3d(-0.6, 0.1, 0.2));
  const Scene scene = observe(randomPlane(300, 3), truth, 0.7, 4);
  const TwoViewResult r = reconstructTwoView(scene.xy_first, scene.xy_second, kFocal, {});
  EXPECT_TRUE(r.used_homography) << r.gric_homography << " vs " << r.gric_essential;
  expectRecovers(scene, truth, r);
}

TEST(TwoViewReconstruction, RefusesPureRotation) {
  const geometry::SE3 truth(geometry::expSO3(Eigen::Vector3d(0.02, 0.12, -0.03)),
                            Eigen::Vector3d::Zero());
  const Scene scene = observe(randomBox(300, 5), truth, 0.7, 6);
  const TwoViewResult r = reconstructTwoView(scene.xy_first, scene.xy_second, kFocal, {});
  EXPECT_FALSE(r.success);
  EXPECT_FALSE(r.reason.empty());
}

TEST(TwoViewReconstruction, RefusesTooLittleBaseline) {
  const geometry::SE3 truth(geometry::expSO3(Eigen::Vector3d(0.0, 0.03, 0.0)),
                            Eigen::Vector3d(0.01, 0.0, 0.0));  // 0.1 deg of parallax at 5 m
  const Scene scene = observe(randomBox(300, 7), truth, 0.7, 8);
  EXPECT_FALSE(reconstructTwoView(scene.xy_first, scene.xy_second, kFocal, {}).success);
}

TEST(TwoViewReconstruction, DegenerateInputIsRefusedNotCrashed) {
  const std::vector<Eigen::Vector2d> few(5, Eigen::Vector2d(0.1, 0.2));
  EXPECT_FALSE(reconstructTwoView(few, few, kFocal, {}).success);
  const std::vector<Eigen::Vector2d> same(200, Eigen::Vector2d(0.1, 0.2));
  EXPECT_FALSE(reconstructTwoView(same, same, kFocal, {}).success);
  EXPECT_FALSE(reconstructTwoView(same, few, kFocal, {}).success);
  TwoViewParams bad;
  bad.ambiguity_ratio = 1.5;
  EXPECT_THROW(bad.validate(), std::invalid_argument);
}

TEST(TwoViewReconstruction, TriangulatesExactly) {
  const geometry::SE3 T(geometry::expSO3(Eigen::Vector3d(0.1, -0.2, 0.05)),
                        Eigen::Vector3d(0.3, -0.1, 0.2));
  const Eigen::Vector3d p(0.4, -0.3, 5.0);
  const Eigen::Vector3d q = T * p;
  EXPECT_LT((triangulateTwoView(p.hnormalized(), q.hnormalized(), T) - p).norm(), 1e-9);
  EXPECT_NEAR(parallaxDeg(Eigen::Vector3d(0, 0, 1),
                          geometry::SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-1, 0, 0))),
              45.0, 1e-9);
}

}  // namespace
}  // namespace scale_drift_slam::tracking
