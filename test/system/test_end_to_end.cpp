// End to end on render_sequence's scenes (sim::SequenceRenderer, 640x480, 1 grey level... see the
// cases): the SLAM (tracker + window BA on the mapping thread, default parameters) must track every
// frame after initialisation and its trajectory, aligned by a similarity, must be within the
// issue's bound of the true one: 1% of the path for office_orbit, 2% for corridor_straight,
// also with lens distortion and with the exposure change. About 35 s in all.

#include <cstdio>

#include <gtest/gtest.h>

#include "scale_drift_slam/evaluation/alignment.h"
#include "scale_drift_slam/sim/sequence.h"
#include "scale_drift_slam/system/slam_system.h"

namespace scale_drift_slam::system {
namespace {

struct Case {
  std::string scene;
  int frames;
  std::string distortion;
  double exposure;
  double max_ate_fraction;  ///< ATE / path length.
};

void PrintTo(const Case& c, std::ostream* os) {
  *os << c.scene << " " << c.frames << " frames, distortion " << c.distortion << ", exposure "
      << c.exposure;
}

class EndToEnd : public ::testing::TestWithParam<Case> {};

TEST_P(EndToEnd, TracksEveryFrameWithinTheErrorBound) {
  const Case& c = GetParam();
  sim::SequenceParams sequence;
  sequence.scene = c.scene;
  sequence.max_frames = c.frames;
  sequence.distortion = c.distortion;
  sequence.realism.noise_sigma = 1.0;
  sequence.realism.exposure_amplitude = c.exposure;
  sim::SequenceRenderer renderer(sequence);
  const system::SlamParams params;
  system::SlamSystem slam(geometry::makeCameraModel(renderer.calibration()), params);
  std::vector<Eigen::Vector3d> estimate, truth;
  int first_tracked = -1, lost = 0;
  for (int k = 0; k < renderer.frameCount(); ++k) {
    const sim::RenderedFrame frame = renderer.render(k);
    const tracking::FrameResult r =
        slam.processFrame(frame.timestamp, frame.image, features::encodingOfMat(frame.image));
    lost += r.state == tracking::TrackingState::kLost;
    if (!r.has_pose) {
      EXPECT_LT(first_tracked, 0) << "frame " << k << " not tracked: " << r.message;
      continue;
    }
    if (first_tracked < 0) first_tracked = k;
    estimate.push_back(r.T_cam_world.inverseTranslation());
    truth.push_back(frame.T_world_cam.translation());
  }
  slam.finish();
  ASSERT_GE(first_tracked, 0) << "never initialised";
  EXPECT_LT(first_tracked, 30);
  EXPECT_EQ(lost, 0);
  const geometry::Sim3 S = evaluation::alignSim3(estimate, truth);
  std::vector<Eigen::Vector3d> aligned;
  for (const auto& p : estimate)
    aligned.push_back(S * p);
  const double ate = evaluation::positionRmse(aligned, truth);
  double path = 0.0;
  for (std::size_t i = 1; i < truth.size(); ++i)
    path += (truth[i] - truth[i - 1]).norm();
  std::printf(
      "%s: %zu of %d frames tracked from %d, %zu keyframes, ATE %.4f m = %.3f%% of %.2f m\n",
      c.scene.c_str(), estimate.size(), renderer.frameCount(), first_tracked,
      slam.map().numKeyframes(), ate, 100 * ate / path, path);
  EXPECT_LT(ate, c.max_ate_fraction * path);
}

INSTANTIATE_TEST_SUITE_P(RenderedScenes, EndToEnd,
                         ::testing::Values(Case{"office_orbit", 0, "none", 0.0, 0.01},
                                           Case{"corridor_straight", 300, "none", 0.0, 0.02},
                                           Case{"office_orbit", 300, "radtan", 0.0, 0.01},
                                           Case{"corridor_straight", 300, "radtan", 0.0, 0.02},
                                           Case{"office_orbit", 300, "none", 0.3, 0.01},
                                           Case{"corridor_straight", 300, "none", 0.3, 0.02}));

}  // namespace
}  // namespace scale_drift_slam::system
