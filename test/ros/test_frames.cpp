// The tf frames: the optical -> body rotation of REP 103, an upright map, map -> odom identity
// without loop corrections, and after a Sim(3) correction the odom pose stays continuous while
// map -> odom -> camera remains exactly the tracker's pose.

#include <gtest/gtest.h>

#include "scale_drift_slam/ros/frames.h"

namespace scale_drift_slam::ros_conversions {
namespace {

geometry::SE3 somePose() {
  geometry::SE3::Tangent xi;
  xi << 0.3, -0.2, 0.1, 0.4, 1.1, -0.7;
  return geometry::SE3::exp(xi);
}

double distance(const geometry::SE3& a, const geometry::SE3& b) {
  return (a.matrix() - b.matrix()).norm();
}

TEST(Frames, OpticalAxesInTheBodyFrame) {
  const geometry::SE3 T_body_optical = bodyFromOptical();
  // Optical z (forward) is body x, optical x (right) is body -y, optical y (down) is body -z.
  EXPECT_LT((T_body_optical * Eigen::Vector3d::UnitZ() - Eigen::Vector3d::UnitX()).norm(), 1e-15);
  EXPECT_LT((T_body_optical * Eigen::Vector3d::UnitX() + Eigen::Vector3d::UnitY()).norm(), 1e-15);
  EXPECT_LT((T_body_optical * Eigen::Vector3d::UnitY() + Eigen::Vector3d::UnitZ()).norm(), 1e-15);
  EXPECT_LT(distance(mapFromWorld(false), geometry::SE3()), 1e-15);
  EXPECT_LT(distance(mapFromWorld(true), T_body_optical), 1e-15);
}

TEST(Frames, FirstCameraIsAtTheMapOriginLookingAlongX) {
  const OdomFrame frames(true);
  const CameraTransforms t = frames.transforms(geometry::SE3());  // the first keyframe
  EXPECT_LT(distance(t.T_map_body, geometry::SE3()), 1e-15);
  // A camera 2 units ahead (optical z) of the first is 2 units along map x.
  const geometry::SE3 ahead(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, -2));
  EXPECT_LT((frames.transforms(ahead).T_map_body.translation() - Eigen::Vector3d(2, 0, 0)).norm(),
            1e-15);
}

TEST(Frames, WithoutCorrectionMapToOdomIsIdentity) {
  for (const bool z_up : {true, false}) {
    const OdomFrame frames(z_up);
    const CameraTransforms t = frames.transforms(somePose());
    EXPECT_LT(distance(t.T_map_odom, geometry::SE3()), 1e-14);
    EXPECT_LT(distance(t.T_odom_body, t.T_map_body), 1e-14);
    // map -> body is the tracker's pose through the fixed rotations.
    const geometry::SE3 expected =
        mapFromWorld(z_up) * somePose().inverse() * bodyFromOptical().inverse();
    EXPECT_LT(distance(t.T_map_body, expected), 1e-14);
  }
}

TEST(Frames, LoopCorrectionsKeepOdomContinuousAndMapExact) {
  OdomFrame frames(true);
  const geometry::SE3 T_cam_world = somePose();
  const CameraTransforms before = frames.transforms(T_cam_world);
  // Two loop corrections with scale; the tracker's map (and its next pose) moves with them.
  geometry::Sim3::Tangent a, b;
  a << 0.05, -0.1, 0.2, std::log(1.7), 0.3, -0.4, 1.0;
  b << -0.02, 0.03, 0.01, std::log(0.8), -1.0, 0.2, 0.1;
  geometry::Sim3 total;
  for (const geometry::Sim3& S : {geometry::Sim3::exp(a), geometry::Sim3::exp(b)}) {
    frames.applyCorrection(S);
    total = S * total;
  }
  EXPECT_LT((frames.correction().matrix() - total.matrix()).norm(), 1e-12);
  // The corrected camera: centre moved by the similarity, rotation by its rotation.
  const geometry::SE3 T_world_cam = T_cam_world.inverse();
  const geometry::SE3 T_world_cam_corrected(total.rotation() * T_world_cam.rotation(),
                                            total * T_world_cam.translation());
  const CameraTransforms after = frames.transforms(T_world_cam_corrected.inverse());
  EXPECT_LT(distance(after.T_odom_body, before.T_odom_body), 1e-12);  // odom did not jump
  EXPECT_LT(distance(after.T_map_odom * after.T_odom_body, after.T_map_body), 1e-12);
  EXPECT_GT(distance(after.T_map_odom, geometry::SE3()), 0.1);  // the correction is in map->odom
  frames.reset();
  EXPECT_LT(distance(frames.transforms(T_cam_world).T_map_odom, geometry::SE3()), 1e-14);
}

}  // namespace
}  // namespace scale_drift_slam::ros_conversions
