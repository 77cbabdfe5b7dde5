// Sequences: deterministic for a seed, the realism flags do what they say, the TUM folder holds
// exactly the rendered frames, stamps and poses, and bad parameters are refused with a reason.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "scale_drift_slam/io/calibration_io.h"
#include "scale_drift_slam/io/trajectory_io.h"
#include "scale_drift_slam/sim/renderer.h"
#include "scale_drift_slam/sim/scenario.h"
#include "scale_drift_slam/sim/sequence.h"
#include "scale_drift_slam/sim/sequence_writer.h"

namespace scale_drift_slam::sim {
namespace {

SequenceParams smallParams(const std::string& scene) {
  SequenceParams params;
  params.scene = scene;
  params.width = 160;
  params.height = 120;
  params.max_frames = 3;
  return params;
}

bool identical(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}

TEST(Sequence, SameSeedSameImagesOtherSeedOtherImages) {
  for (const std::string& scene : scenarioNames()) {
    // city_tour is city_loop's generator on a longer route; its city takes ~18 s to build.
    if (scene == "city_tour") continue;
    SequenceParams params = smallParams(scene);
    params.realism.noise_sigma = 2.0;
    SequenceRenderer a(params), b(params);
    const RenderedFrame fa = a.render(2), fb = b.render(2);
    SCOPED_TRACE(scene);
    EXPECT_TRUE(identical(fa.image, fb.image));
    if (scene == "office_orbit") {  // another seed: other textures (one scene suffices)
      params.seed = 2;
      EXPECT_FALSE(identical(fa.image, SequenceRenderer(params).render(2).image));
    }
    EXPECT_EQ(fa.stamp_ns, fb.stamp_ns);
    EXPECT_LT((fa.T_world_cam.matrix() - fb.T_world_cam.matrix()).norm(), 1e-15);
  }
}

TEST(Sequence, FrameCountsAndStampsFollowTheScenario) {
  SequenceParams params;
  params.scene = "courtyard_loop";
  params.width = 64;
  params.height = 48;
  SequenceRenderer renderer(params);
  EXPECT_EQ(renderer.frameCount(), 900);
  EXPECT_EQ(renderer.pose(30).stamp_ns, 1001000000000LL);
  params.scene = "office_orbit";
  EXPECT_EQ(SequenceRenderer(params).frameCount(), 600);
  params.scene = "corridor_straight";
  params.rate = 15;
  EXPECT_EQ(SequenceRenderer(params).frameCount(), 300);
  // The courtyard loop closes: after the loop the camera passes its start again.
  double closest = 1e9;
  for (int i = 800; i < 900; ++i) {
    closest = std::min(closest, (renderer.pose(i).T_world_cam.translation() -
                                 renderer.pose(0).T_world_cam.translation())
                                    .norm());
  }
  EXPECT_LT(closest, 0.2);
}

TEST(Sequence, RealismFlagsChangeTheImagesAsSpecified) {
  SequenceParams params = smallParams("office_orbit");
  params.realism.optics_blur = 0.0;
  const cv::Mat clean = SequenceRenderer(params).render(1).image;

  SequenceParams noisy = params;
  noisy.realism.noise_sigma = 5.0;
  cv::Mat difference;
  cv::Mat(SequenceRenderer(noisy).render(1).image).convertTo(difference, CV_32F);
  cv::Mat clean_float;
  clean.convertTo(clean_float, CV_32F);
  cv::Scalar mean, stddev;
  cv::meanStdDev(difference - clean_float, mean, stddev);
  EXPECT_NEAR(stddev[0], 5.0, 0.7);

  SequenceParams dark = params;
  dark.realism.blackout_start = 0.0;
  dark.realism.blackout_duration = 0.05;  // frames 0 and 1 at 30 Hz
  SequenceRenderer blackout(dark);
  EXPECT_EQ(cv::countNonZero(blackout.render(1).image), 0);
  EXPECT_GT(cv::countNonZero(blackout.render(2).image), 0);

  // Exposure: the brightness ratio to the clean frame swings by about 2 x amplitude over a period.
  SequenceParams bright = params;
  bright.max_frames = 6;
  bright.realism.exposure_amplitude = 0.3;
  bright.realism.exposure_period = 0.2;  // 6 frames at 30 Hz
  SequenceParams reference = bright;
  reference.realism.exposure_amplitude = 0.0;
  SequenceRenderer exposure(bright), unexposed(reference);
  double lowest = 1e9, highest = 0;
  for (int i = 0; i < 6; ++i) {
    const double ratio =
        cv::mean(exposure.render(i).image)[0] / cv::mean(unexposed.render(i).image)[0];
    lowest = std::min(lowest, ratio);
    highest = std::max(highest, ratio);
  }
  EXPECT_GT(highest - lowest, 0.4);
  EXPECT_LT(highest - lowest, 0.62);

  SequenceParams blurred = params;
  blurred.realism.motion_blur = 0.03;
  cv::Mat edges_clean, edges_blurred;
  cv::Laplacian(clean, edges_clean, CV_32F);
  cv::Laplacian(SequenceRenderer(blurred).render(1).image, edges_blurred, CV_32F);
  EXPECT_LT(cv::norm(edges_blurred), 0.9 * cv::norm(edges_clean));

  SequenceParams colour = params;
  colour.color = true;
  EXPECT_EQ(SequenceRenderer(colour).render(0).image.type(), CV_8UC3);
}

TEST(Sequence, TumFolderHoldsTheFramesStampsAndPoses) {
  const std::string directory = std::string(SDS_TEST_OUTPUT_DIR) + "/sim_tum_folder";
  std::filesystem::remove_all(directory);
  SequenceParams params = smallParams("corridor_straight");
  params.distortion = "radtan";
  SequenceRenderer renderer(params);
  std::vector<RenderedFrame> frames;
  {
    TumSequenceWriter writer(directory, renderer.calibration());
    for (int i = 0; i < renderer.frameCount(); ++i) {
      frames.push_back(renderer.render(i));
      writer.add(frames.back());
    }
  }
  const std::vector<io::StampedPose> truth = io::loadTrajectory(directory + "/groundtruth.txt");
  ASSERT_EQ(truth.size(), frames.size());
  std::ifstream list(directory + "/rgb.txt");
  std::string line;
  size_t i = 0;
  while (std::getline(list, line)) {
    if (line.empty() || line[0] == '#') continue;
    ASSERT_LT(i, frames.size());
    const std::string stamp = TumSequenceWriter::formatStamp(frames[i].stamp_ns);
    EXPECT_EQ(line, stamp + " rgb/" + stamp + ".png");
    EXPECT_TRUE(identical(cv::imread(directory + "/rgb/" + stamp + ".png", cv::IMREAD_UNCHANGED),
                          frames[i].image));
    EXPECT_NEAR(truth[i].timestamp, frames[i].timestamp, 1e-9);
    EXPECT_LT((truth[i].T_world_cam.matrix() - frames[i].T_world_cam.matrix()).norm(), 1e-12);
    ++i;
  }
  EXPECT_EQ(i, frames.size());
  const geometry::CameraCalibration loaded = io::loadCalibrationYaml(directory + "/camera.yaml");
  EXPECT_EQ(loaded.model, renderer.calibration().model);
  EXPECT_EQ(loaded.distortion, renderer.calibration().distortion);
  EXPECT_DOUBLE_EQ(loaded.fx, renderer.calibration().fx);
  EXPECT_EQ(TumSequenceWriter::formatStamp(1000033333333LL), "1000.033333333");
}

TEST(Sequence, DeskIsMostlyOnePlaneSeenThroughTheTumLensStillForTenFrames) {
  SequenceParams params;
  params.scene = "desk";
  SequenceRenderer sequence(params);
  EXPECT_EQ(sequence.frameCount(), 300);
  EXPECT_EQ(sequence.calibration().distortion.front(), 0.2624);  // the scene's lens by default
  // Still for frames 0-10 (the motion starts right after frame 10), moving from frame 11.
  const geometry::SE3 still = sequence.pose(0).T_world_cam;
  EXPECT_LT((sequence.pose(10).T_world_cam.matrix() - still.matrix()).norm(), 1e-12);
  EXPECT_GT((sequence.pose(11).T_world_cam.translation() - still.translation()).norm(), 1e-5);
  // The desk top is surface 0; everything else (objects, wall, floor) is off the plane.
  Renderer renderer(sequence.camera());
  double sum = 0.0, least = 1.0, most = 0.0;
  int count = 0;
  for (int i = 0; i < sequence.frameCount(); i += 15, ++count) {
    cv::Mat image;
    renderer.render(sequence.scenario().scene, sequence.pose(i).T_world_cam.inverse(), image);
    const double off =
        1.0 - cv::countNonZero(renderer.surfaceIndex() == 0) / static_cast<double>(image.total());
    sum += off;
    least = std::min(least, off);
    most = std::max(most, off);
  }
  std::printf("desk: off-plane share of the image %.1f %% on average, %.1f-%.1f %%\n",
              100 * sum / count, 100 * least, 100 * most);
  EXPECT_GT(sum / count, 0.08);
  EXPECT_LT(sum / count, 0.25);
  EXPECT_LT(most, 0.35);
}

/// Times the camera comes within `radius` metres (x-y) of where it started: maximal runs of
/// samples every 0.1 s within the radius.
int visitsOfTheStart(const Scenario& scenario, double radius) {
  const Eigen::Vector2d start = scenario.T_world_cam(0.0).translation().head<2>();
  int visits = 0;
  bool near = false;
  for (double t = 0.0; t <= scenario.duration; t += 0.1) {
    const bool now = (scenario.T_world_cam(t).translation().head<2>() - start).norm() < radius;
    if (now && !near) ++visits;
    near = now;
  }
  return visits;
}

TEST(Sequence, CityLoopLapsDriveTheWholeRouteAgainInTheSameCity) {
  const Scenario one = makeScenario("city_loop", 1);
  ScenarioOptions laps;
  laps.laps = 3;
  const Scenario three = makeScenario("city_loop", 1, laps);
  // The same city (the route covers the same streets), the same start.
  EXPECT_EQ(three.scene.textureCount(), one.scene.textureCount());
  EXPECT_LT((three.T_world_cam(0.0).translation() - one.T_world_cam(0.0).translation()).norm(),
            1e-9);
  // One lap passes its start three times (start, the second loop, the end past the start); each
  // further lap twice more (the first loop's west street, then the second loop's).
  EXPECT_EQ(visitsOfTheStart(one, 3.0), 3);
  EXPECT_EQ(visitsOfTheStart(three, 3.0), 7);
  // Both end a little past the start, heading north, in the same lane.
  const Eigen::Vector3d end_one = one.T_world_cam(one.duration).translation();
  const Eigen::Vector3d end_three = three.T_world_cam(three.duration).translation();
  EXPECT_LT((end_one - end_three).head<2>().norm(), 0.5);
  EXPECT_GT(three.duration, 2.8 * one.duration);
  EXPECT_LT(three.duration, 3.2 * one.duration);
  laps.laps = 0;
  EXPECT_THROW(makeScenario("city_loop", 1, laps), std::invalid_argument);
  laps.laps = 2;
  EXPECT_THROW(makeScenario("city_block", 1, laps), std::invalid_argument);
  SequenceParams params = smallParams("courtyard_loop");
  params.laps = 2;
  EXPECT_THROW(SequenceRenderer{params}, std::invalid_argument);
}

// --turn-rate: the car's yaw rate in the turns of a city drive. The peak over 0.1 s steps is the
// rate asked (the turns are circular arcs driven at rate x radius); other scenes refuse it
// (BadParametersAreRefusedWithAReason).
TEST(Sequence, ACityDriveTakesItsCornersAtTheTurnRateAsked) {
  const auto peak_yaw_rate_deg_s = [](const Scenario& scenario) {
    double peak = 0.0;
    for (double t = 0.0; t + 0.1 <= scenario.duration; t += 0.1) {
      const Eigen::Vector3d a = scenario.T_world_cam(t).rotationMatrix() * Eigen::Vector3d::UnitZ();
      const Eigen::Vector3d b =
          scenario.T_world_cam(t + 0.1).rotationMatrix() * Eigen::Vector3d::UnitZ();
      const double turn =
          std::abs(std::atan2(a.x() * b.y() - a.y() * b.x(), a.x() * b.x() + a.y() * b.y()));
      peak = std::max(peak, turn / 0.1 * 180.0 / M_PI);
    }
    return peak;
  };
  ScenarioOptions options;
  const Scenario town = makeScenario("city_block", 1, options);
  options.turn_rate_deg_s = 50.0;
  const Scenario fast = makeScenario("city_block", 1, options);
  EXPECT_NEAR(peak_yaw_rate_deg_s(town), 28.6, 2.0);
  EXPECT_NEAR(peak_yaw_rate_deg_s(fast), 50.0, 2.0);
  // The same streets, driven faster through the corners.
  EXPECT_LT(fast.duration, town.duration);
  EXPECT_LT((fast.T_world_cam(0.0).translation() - town.T_world_cam(0.0).translation()).norm(),
            1e-9);
}

TEST(Sequence, BadParametersAreRefusedWithAReason) {
  auto refuses = [](const std::function<void(SequenceParams&)>& change) {
    SequenceParams params = smallParams("office_orbit");
    change(params);
    EXPECT_THROW(SequenceRenderer renderer(params), std::invalid_argument);
  };
  refuses([](SequenceParams& p) { p.scene = "moon_base"; });
  refuses([](SequenceParams& p) { p.width = 0; });
  refuses([](SequenceParams& p) { p.rate = -3; });
  refuses([](SequenceParams& p) { p.distortion = "barrel"; });
  refuses([](SequenceParams& p) { p.horizontal_fov_deg = 200; });
  refuses([](SequenceParams& p) { p.realism.noise_sigma = -1; });
  refuses([](SequenceParams& p) { p.realism.exposure_amplitude = 1.5; });
  refuses([](SequenceParams& p) { p.realism.motion_blur_samples = 0; });
  refuses([](SequenceParams& p) { p.turn_rate_deg_s = 50.0; });  // no drive in an office
  refuses([](SequenceParams& p) {
    p.scene = "city_block";
    p.turn_rate_deg_s = 0.0;
  });
  try {
    SequenceParams params;
    params.scene = "moon_base";
    SequenceRenderer renderer(params);
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("courtyard_loop"), std::string::npos);
  }
  EXPECT_THROW(TumSequenceWriter("/proc/forbidden/sequence", geometry::CameraCalibration()),
               std::runtime_error);
}

}  // namespace
}  // namespace scale_drift_slam::sim
