// Two-view initialisation on synthetic correspondences with a known answer: a general 3D scene
// (the essential matrix is chosen), a planar scene (the homography is chosen), both recover the
// motion and the structure up to the scale, normalised to median depth 1; a mostly planar desk
// under small hand-held motion (the homography's two motions both fit the desk) is resolved by
// the points on the objects; pure rotation and too little baseline are refused with a reason.

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

// A desk seen from 0.7 m with the camera pitched down 55 degrees, in the first camera frame;
// `box_share` of the points lie on the tops of four boxes 5-20 cm tall standing on it.
std::vector<Eigen::Vector3d> deskWithBoxes(int n, double box_share, std::mt19937* rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0), u01(0.0, 1.0);
  const double pitch = 55.0 * M_PI / 180.0, distance = 0.7;
  const Eigen::Vector3d normal(0.0, std::cos(pitch), std::sin(pitch));  // desk: normal.p = 0.7
  const Eigen::Vector3d e1 = normal.cross(Eigen::Vector3d::UnitX()).normalized();
  const Eigen::Vector3d e2 = normal.cross(e1);
  std::vector<Eigen::Vector3d> box_tops;
  std::vector<double> box_sizes;
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector3d ray(0.4 * u(*rng), 0.3 * u(*rng), 1.0);
    const double height = 0.05 + 0.15 * u01(*rng);
    box_tops.push_back(ray * distance / normal.dot(ray) - height * normal);
    box_sizes.push_back(0.05 + 0.05 * u01(*rng));
  }
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < n; ++i) {
    if (u01(*rng) < box_share) {
      const int k = static_cast<int>((*rng)() % box_tops.size());
      points.push_back(box_tops[k] + box_sizes[k] * (u(*rng) * e1 + u(*rng) * e2));
    } else {
      const Eigen::Vector3d ray(0.6 * u(*rng), 0.45 * u(*rng), 1.0);
      points.push_back(ray * distance / normal.dot(ray));
    }
  }
  return points;
}

// Hand-held: about 2 degrees of rotation and 4 cm of mostly sideways translation.
geometry::SE3 handHeldMotion(std::mt19937* rng) {
  std::normal_distribution<double> g(0.0, 1.0);
  const Eigen::Vector3d omega(0.02 * g(*rng), 0.02 * g(*rng), 0.02 * g(*rng));
  const Eigen::Vector3d t(g(*rng), 0.3 * g(*rng), 0.3 * g(*rng));
  return geometry::SE3(geometry::expSO3(omega), 0.04 * t.normalized());
}

struct DeskTally {
  int initialised = 0, resolved = 0, wrong = 0;
};

// Reconstructs `runs` desks; counts the successes and those off the truth by more than the
// tolerance (the homography's other motion is 20-60 degrees off in its direction).
DeskTally reconstructDesks(double box_share, int runs) {
  DeskTally tally;
  for (int run = 0; run < runs; ++run) {
    std::mt19937 rng(100 + run);
    const geometry::SE3 truth = handHeldMotion(&rng);
    const Scene scene = observe(deskWithBoxes(450, box_share, &rng), truth, 0.7, 200 + run);
    const TwoViewResult r = reconstructTwoView(scene.xy_first, scene.xy_second, kFocal, {});
    if (!r.success) continue;
    ++tally.initialised;
    tally.resolved += r.ambiguity_resolved;
    const double direction_deg =
        std::acos(std::clamp(
            r.T_second_first.translation().normalized().dot(truth.translation().normalized()), -1.0,
            1.0)) *
        180.0 / M_PI;
    if (rotationErrorDeg(r.T_second_first, truth) > 0.6 || direction_deg > 10.0) ++tally.wrong;
  }
  return tally;
}

TEST(TwoViewReconstruction, MostlyPlanarDeskUnderHandHeldMotionResolvesTheAmbiguity) {
  // Both of the homography's motions fit the desk; 15% of the points on the boxes decide. The
  // old rule (wait until the runner-up keeps < 70% of the points) refused 11 of these 30.
  const DeskTally tally = reconstructDesks(0.15, 30);
  EXPECT_GE(tally.initialised, 25);
  EXPECT_GE(tally.resolved, 4);  // the ambiguity was met and resolved, not just absent
  EXPECT_EQ(tally.wrong, 0);
}

TEST(TwoViewReconstruction, SinglePlaneNeverStartsFromTheWrongMotion) {
  // Nothing off the plane tells the two motions apart: refusing is right, guessing is not.
  const DeskTally tally = reconstructDesks(0.0, 30);
  EXPECT_EQ(tally.wrong, 0);
}

// The DAVIS240C slider case (doc/frontend.md, "Rotation or translation"): a 240x180 camera with a
// 39-degree lens (f = 335 px) sliding sideways past a wall it faces at depth 1. Over a few pixels
// of image motion a rotation about the vertical axis moves the points almost as the sideways
// translation does; with the depths free the reconstruction trades one for the other and
// reports an inflated parallax (the real sequence started a map with 5.8 degrees from 0.9). The
// initialiser waits until the rotation's uncertainty is a tenth of the parallax.
struct SlideTally {
  int started = 0, wrong = 0;
};

SlideTally reconstructSlides(double flow_px, double noise_px, int runs,
                             const TwoViewParams& params = {}) {
  constexpr double kNarrowFocal = 335.0;
  SlideTally tally;
  for (int run = 0; run < runs; ++run) {
    std::mt19937 rng(500 + run);
    std::uniform_real_distribution<double> u(-0.45, 0.45), v(-0.35, 0.35);
    std::normal_distribution<double> noise(0.0, noise_px / kNarrowFocal);
    const geometry::SE3 truth(Eigen::Quaterniond::Identity(),
                              Eigen::Vector3d(-flow_px / kNarrowFocal, 0.0, 0.0));
    std::vector<Eigen::Vector2d> a, b;
    while (a.size() < 150) {
      const double x = u(rng), y = v(rng);
      const Eigen::Vector3d p(x, y, 1.0 + 0.07 * x - 0.03 * y);  // the wall, almost facing
      const Eigen::Vector2d pa = p.hnormalized(), pb = (truth * p).hnormalized();
      if (std::abs(pa.x()) > 0.36 || std::abs(pb.x()) > 0.36 || std::abs(pa.y()) > 0.27 ||
          std::abs(pb.y()) > 0.27)
        continue;  // outside the 240x180 image
      a.push_back(pa + Eigen::Vector2d(noise(rng), noise(rng)));
      b.push_back(pb + Eigen::Vector2d(noise(rng), noise(rng)));
    }
    const TwoViewResult r = reconstructTwoView(a, b, kNarrowFocal, params);
    if (!r.success) continue;
    ++tally.started;
    const double true_parallax_deg = std::atan(flow_px / kNarrowFocal) * 180.0 / M_PI;
    if (rotationErrorDeg(r.T_second_first, truth) > 0.25 * true_parallax_deg ||
        std::abs(r.median_parallax_deg - true_parallax_deg) > 0.25 * true_parallax_deg)
      ++tally.wrong;
  }
  return tally;
}

TEST(TwoViewReconstruction, NarrowLensSlidingPastAWallWaitsUntilRotationIsToldApart) {
  // 5, 10 and 20 px of image motion (0.85-3.4 deg of parallax), 0.5 px of noise: without the
  // rotation check 12, 19 and 20 of 20 started, 12, 15 and 9 of them with the rotation or the
  // parallax off by more than a quarter of the true parallax; now none starts wrong.
  for (double flow_px : {5.0, 10.0, 20.0}) {
    const SlideTally small = reconstructSlides(flow_px, 0.5, 20);
    EXPECT_EQ(small.wrong, 0) << flow_px << " px: " << small.started << " started";
  }
  // 1 px of noise, 5 px of motion: 11 of 20 started, all wrong, before.
  EXPECT_EQ(reconstructSlides(5.0, 1.0, 20).wrong, 0);
  // 40 px (6.8 deg) with 0.5 px of noise: told apart well enough, and the map starts.
  const SlideTally enough = reconstructSlides(40.0, 0.5, 20);
  EXPECT_EQ(enough.wrong, 0);
  EXPECT_GE(enough.started, 15);
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
