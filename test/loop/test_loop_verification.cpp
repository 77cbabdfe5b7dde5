// Loop verification on rendered views of a textured room with a known answer: the loop keyframe
// sees the far wall from one place, the current keyframe from another, and the current keyframe's
// map is in different units (scale drift s). verifyLoop must recover the relative pose and s from
// ORB matches, regressed depths, P3P RANSAC, the warped-patch search and the 3D-3D ratios; a
// wrong association is refused with a reason; verifyPose localises a frame without a map.

#include <cstdio>
#include <map>
#include <random>

#include <gtest/gtest.h>

#include "../tracking/synthetic_images.h"
#include "scale_drift_slam/geometry/so3.h"
#include "scale_drift_slam/loop/loop_verification.h"

namespace scale_drift_slam::loop {
namespace {

constexpr int kWidth = 640, kHeight = 480;
constexpr double kWall = 4.0;  // the far wall is the plane z = 4 m

std::shared_ptr<const geometry::CameraModel> camera() {
  return test::pinholeCamera(450.0);
}

struct View {
  cv::Mat image;
  KeyframeAppearance features;
  VerificationView verification;
};

/// The view from T_cam_world; its map points are wall points it sees, in its camera frame,
/// multiplied by `map_scale` (the units of its part of a drifting map).
View makeView(const std::vector<test::TexturedPlane>& room, const geometry::CameraModel& cam,
              const geometry::SE3& T_cam_world, double map_scale, bool with_points, unsigned seed) {
  View view;
  view.image = test::renderPlanes(room, cam.K(), T_cam_world, kWidth, kHeight);
  AppearanceExtractor extractor{AppearanceParams{}};
  view.features = extractor.extract(view.image, &cam);
  view.verification.image = features::buildPyramid(view.image, 2);
  if (!with_points) return view;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> x(-3.8, 3.8), y(-1.8, 1.8);
  for (map::PointId id = 0; view.verification.point_ids.size() < 250 && id < 5000; ++id) {
    const Eigen::Vector3d p_cam = T_cam_world * Eigen::Vector3d(x(rng), y(rng), kWall);
    const std::optional<Eigen::Vector2d> px = cam.project(p_cam);
    if (!px || !cam.isInImage(*px, 20.0)) continue;
    view.verification.point_ids.push_back(id);
    view.verification.point_xy.push_back(p_cam.head<2>() / p_cam.z());
    view.verification.point_camera.push_back(map_scale * p_cam);
  }
  return view;
}

std::vector<DescriptorMatch> inlierMatches(const View& current, const View& candidate) {
  const PlaceRecognitionParams params;
  const std::vector<DescriptorMatch> matches =
      matchDescriptors(current.features, candidate.features, params.geometry);
  return checkGeometry(current.features, candidate.features, matches, params.geometry)
      .inlier_matches;
}

struct Scene {
  std::vector<test::TexturedPlane> room = test::boxRoom(4.0, 2.0, 4.0, 40);
  std::shared_ptr<const geometry::CameraModel> cam = camera();
  geometry::SE3 T_loop_world;
  geometry::SE3 T_current_world{geometry::expSO3(Eigen::Vector3d(0.02, 0.14, -0.03)),
                                Eigen::Vector3d(-0.35, 0.1, -0.3)};
};

TEST(LoopVerification, RecoversThePoseAndTheScaleDrift) {
  Scene scene;
  const double drift = 1.37;  // current map units per loop map unit
  View loop = makeView(scene.room, *scene.cam, scene.T_loop_world, 1.0, true, 1);
  View current = makeView(scene.room, *scene.cam, scene.T_current_world, drift, true, 2);
  loop.verification.features = &loop.features;
  current.verification.features = &current.features;
  const std::vector<DescriptorMatch> matches = inlierMatches(current, loop);
  ASSERT_GT(matches.size(), 100u);

  const LoopVerification v = verifyLoop(current.verification, loop.verification, matches,
                                        *scene.cam, LoopVerificationParams{});
  ASSERT_TRUE(v.success) << v.reason;
  const geometry::SE3 T_true = scene.T_current_world * scene.T_loop_world.inverse();
  const geometry::SE3 error = v.constraint.T_current_loop * T_true.inverse();
  std::printf(
      "scale %.4f (true %.2f), rotation error %.2e rad, translation error %.2e m, "
      "%d descriptor matches, %d RANSAC inliers, %d found, %d final inliers\n",
      v.constraint.scale, drift, error.log().head<3>().norm(), error.translation().norm(),
      v.descriptor_matches, v.ransac_inliers, v.found_points, v.constraint.num_inliers);
  EXPECT_LT(error.log().head<3>().norm(), 2e-3);  // rad
  EXPECT_LT(error.translation().norm(), 0.01);    // m (loop units = metres here)
  EXPECT_NEAR(v.constraint.scale, drift, 0.02 * drift);
  EXPECT_GT(v.found_points, 150);  // the warped-patch search adds the loop keyframe's points
  EXPECT_GT(v.constraint.num_inliers, v.ransac_inliers);
  EXPECT_LT(v.constraint.rmse_px, 1.0);
  EXPECT_GT(v.constraint.num_scale_pairs, 100);
  // The similarity maps loop-keyframe points into the current keyframe's units.
  const Eigen::Vector3d p_loop = loop.verification.point_camera[0];
  EXPECT_LT((v.constraint.S_current_loop * p_loop - drift * (T_true * p_loop)).norm(), 0.03);
}

TEST(LoopVerification, LocalisesAFrameWithoutAMapOfItsOwn) {
  Scene scene;
  View loop = makeView(scene.room, *scene.cam, scene.T_loop_world, 1.0, true, 1);
  View frame = makeView(scene.room, *scene.cam, scene.T_current_world, 1.0, false, 2);
  loop.verification.features = &loop.features;
  frame.verification.features = &frame.features;
  const LoopVerification v =
      verifyPose(frame.verification, loop.verification, inlierMatches(frame, loop), *scene.cam,
                 LoopVerificationParams{});
  ASSERT_TRUE(v.success) << v.reason;
  const geometry::SE3 error = v.constraint.T_current_loop *
                              (scene.T_current_world * scene.T_loop_world.inverse()).inverse();
  EXPECT_LT(error.translation().norm(), 0.01);
  ASSERT_GT(v.inlier_points.size(), 100u);
  // Each map point found in the frame lies where the true pose projects it.
  std::map<map::PointId, Eigen::Vector3d> in_loop;
  for (std::size_t i = 0; i < loop.verification.point_ids.size(); ++i)
    in_loop[loop.verification.point_ids[i]] = loop.verification.point_camera[i];
  double worst = 0.0;
  for (const FoundPoint& p : v.inlier_points) {
    const Eigen::Vector3d p_world = scene.T_loop_world.inverse() * in_loop.at(p.id);
    const Eigen::Vector2d truth = *scene.cam->project(scene.T_current_world * p_world);
    worst = std::max(worst, (p.px - truth).norm());
  }
  EXPECT_LT(worst, 3.0);
}

TEST(LoopVerification, RefusesWrongAssociationsWithAReason) {
  Scene scene;
  View loop = makeView(scene.room, *scene.cam, scene.T_loop_world, 1.0, true, 1);
  View current = makeView(scene.room, *scene.cam, scene.T_current_world, 1.0, true, 2);
  loop.verification.features = &loop.features;
  current.verification.features = &current.features;
  std::vector<DescriptorMatch> matches = inlierMatches(current, loop);
  // Scramble the association: every current keypoint paired with a random loop keypoint.
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> any(0, static_cast<int>(loop.features.size()) - 1);
  for (DescriptorMatch& m : matches)
    m.candidate = any(rng);
  const LoopVerification v = verifyLoop(current.verification, loop.verification, matches,
                                        *scene.cam, LoopVerificationParams{});
  EXPECT_FALSE(v.success);
  EXPECT_FALSE(v.reason.empty());
  // A loop keyframe with no map points: no depths, no constraint.
  loop.verification.point_ids.clear();
  loop.verification.point_xy.clear();
  loop.verification.point_camera.clear();
  const LoopVerification empty =
      verifyLoop(current.verification, loop.verification, inlierMatches(current, loop), *scene.cam,
                 LoopVerificationParams{});
  EXPECT_FALSE(empty.success);
  EXPECT_NE(empty.reason.find("matches"), std::string::npos) << empty.reason;
  // Inconsistent input is an error, not an answer.
  loop.verification.point_ids.push_back(1);
  EXPECT_THROW(
      verifyLoop(current.verification, loop.verification, {}, *scene.cam, LoopVerificationParams{}),
      std::invalid_argument);
}

}  // namespace
}  // namespace scale_drift_slam::loop
