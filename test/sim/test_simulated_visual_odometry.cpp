// The simulated visual odometry on the paper's circle (a 200-pose arc and the full circle): it
// tracks every frame and builds a map of promoted features; and the loop constraint measured from
// the observations at the end of the circle finds the scale drift the map really has.

#include <random>

#include <gtest/gtest.h>

#include "scale_drift_slam/sim/loop_measurement.h"
#include "scale_drift_slam/sim/simulated_visual_odometry.h"

namespace scale_drift_slam::sim {
namespace {

SimulatedVisualOdometry runCircle(const SimulatedWorld& world, double noise, std::mt19937& rng) {
  SimulatedVisualOdometry vo(world.camera, SimulatedVoParams());
  for (std::size_t i = 0; i < world.T_cam_world.size(); ++i)
    vo.processFrame(i, measureFrame(world, i, noise, rng), world.T_cam_world[i]);
  return vo;
}

/// The map's local scale at a keyframe: median over its points of (estimated distance from the
/// camera) / (true distance).
double localScale(const SimulatedVisualOdometry& vo, const SimulatedWorld& world, std::size_t k) {
  const KeyframeRecord& record = vo.keyframes()[k];
  const map::Keyframe& kf = vo.map().keyframe(record.id);
  std::vector<double> ratios;
  for (const map::Observation& o : kf.observations) {
    const double estimated = (kf.T_kf_world * vo.map().point(o.point_id).p_world).norm();
    const double truth =
        (world.T_cam_world[record.frame] * world.points[vo.simPointOf(o.point_id)]).norm();
    ratios.push_back(estimated / truth);
  }
  std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2, ratios.end());
  return ratios[ratios.size() / 2];
}

TEST(SimulatedVisualOdometry, TracksAnArcWithoutNoiseExactly) {
  std::mt19937 rng(1);
  CircleWorldParams world_params;
  world_params.num_poses = 200;
  world_params.arc_fraction = 200.0 / 720.0;
  const SimulatedWorld world = makeCircleWorld(world_params, rng);
  const SimulatedVisualOdometry vo = runCircle(world, 0.0, rng);
  EXPECT_EQ(vo.statistics().lost_frames, 0u);
  EXPECT_GT(vo.map().numKeyframes(), 60u);
  EXPECT_GT(vo.map().numPoints(), 500u);
  // Noise-free: every frame is estimated to within millimetres of the truth.
  for (std::size_t i = 0; i < world.T_cam_world.size(); ++i) {
    EXPECT_LT((vo.framePoses()[i].inverseTranslation() - world.T_cam_world[i].inverseTranslation())
                  .norm(),
              5e-3)
        << i;
  }
}

TEST(SimulatedVisualOdometry, TheMeasuredLoopScaleMatchesTheMapsDrift) {
  std::mt19937 rng(2);
  const SimulatedWorld world = makeCircleWorld(CircleWorldParams(), rng);
  const SimulatedVisualOdometry vo = runCircle(world, 1.0, rng);
  EXPECT_EQ(vo.statistics().lost_frames, 0u);
  EXPECT_GT(vo.map().numPoints(), 2000u);
  EXPECT_GT(vo.statistics().promoted, 10 * vo.statistics().promotions_rejected);
  const std::size_t last = vo.keyframes().size() - 1;
  EXPECT_GE(vo.keyframes()[last].frame, 715u);
  LoopMeasurementParams params;
  params.constraint.ransac_threshold_px = 6.0;
  const loop::LoopConstraintResult loop =
      measureLoop(vo, last, 0, world.camera.focal_length, params);
  ASSERT_TRUE(loop.success) << loop.reason;
  // 1 px noise drifts the scale by tens of percent around the circle (the paper: clearly
  // visible drift); the constraint measures the ratio of the local scales at both ends.
  const double expected = localScale(vo, world, last) / localScale(vo, world, 0);
  EXPECT_GT(std::abs(std::log(expected)), 0.05);
  EXPECT_NEAR(loop.constraint.scale, expected, 0.03 * expected);
  EXPECT_GT(loop.constraint.num_inliers, 20);
}

}  // namespace
}  // namespace scale_drift_slam::sim
