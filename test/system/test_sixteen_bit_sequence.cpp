// Issue 17: 16-bit PNGs holding 12-bit data (a 12-bit camera's frames) were scaled by 1/256 and
// every frame was rejected as "no texture". End to end as run_sequence reads a folder: rendered
// office_orbit frames of a dim, flat-lit scene (grey 0.2 x + 120: values up to 2736, 12 bits)
// written as 16-bit PNGs, read back by io::openImageFolder and tracked by the SlamSystem: no
// frame rejected, tracked, the bit depth logged exactly once. Read as 16-bit data (as before the
// fix, tracker.mono16_bit_depth 16) every frame is rejected as "no texture".

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "scale_drift_slam/io/calibration_io.h"
#include "scale_drift_slam/io/image_sequence.h"
#include "scale_drift_slam/sim/sequence.h"
#include "scale_drift_slam/system/slam_system.h"

namespace scale_drift_slam::system {
namespace {
namespace fs = std::filesystem;

/// Renders the folder once; returns it.
fs::path twelveBitFolder() {
  const fs::path dir = fs::path(SDS_TEST_OUTPUT_DIR) / "sixteen_bit_sequence";
  fs::remove_all(dir);
  fs::create_directories(dir / "rgb");
  sim::SequenceParams params;
  params.scene = "office_orbit";
  params.max_frames = 60;
  params.realism.noise_sigma = 1.0;
  sim::SequenceRenderer renderer(params);
  io::saveCalibrationYaml(renderer.calibration(), (dir / "camera.yaml").string());
  std::ofstream list(dir / "rgb.txt");
  for (int i = 0; i < renderer.frameCount(); ++i) {
    const sim::RenderedFrame frame = renderer.render(i);
    cv::Mat twelve_bit;
    frame.image.convertTo(twelve_bit, CV_16U, 16.0 * 0.2, 16.0 * 120.0);
    const std::string name = "rgb/" + std::to_string(i) + ".png";
    EXPECT_TRUE(cv::imwrite((dir / name).string(), twelve_bit));
    list << std::fixed << frame.timestamp << " " << name << "\n";
  }
  return dir;
}

struct Outcome {
  int frames = 0, rejected = 0, no_texture = 0, tracked = 0, depth_lines = 0, depth = 0;
};

Outcome track(const fs::path& dir, int mono16_bit_depth) {
  const auto sequence = io::openImageFolder(dir.string());
  SlamParams slam_params;
  slam_params.mapping_thread = false;
  slam_params.tracker.mono16_bit_depth = mono16_bit_depth;
  SlamSystem slam(geometry::makeCameraModel(*sequence->calibration()), slam_params);
  Outcome o;
  while (const auto frame = sequence->next()) {
    EXPECT_EQ(frame->image.type(), CV_16UC1);
    const tracking::FrameResult r =
        slam.processFrame(frame->timestamp, frame->image, features::encodingOfMat(frame->image));
    ++o.frames;
    o.rejected += r.rejected ? 1 : 0;
    o.no_texture += r.message.find("no texture") != std::string::npos ? 1 : 0;
    o.tracked += r.has_pose ? 1 : 0;
    for (const std::string& line : slam.takeLog())
      o.depth_lines += line.find("16-bit images are read as ") != std::string::npos;
  }
  slam.finish();
  o.depth = slam.tracker().mono16BitDepth();
  return o;
}

TEST(SixteenBitSequence, TwelveBitPngsAreTrackedAndTheDepthIsLoggedOnce) {
  const fs::path dir = twelveBitFolder();
  const Outcome measured = track(dir, 0);
  EXPECT_EQ(measured.frames, 60);
  EXPECT_EQ(measured.rejected, 0);
  EXPECT_GE(measured.tracked, 45) << "of 60 frames";
  EXPECT_EQ(measured.depth_lines, 1);
  EXPECT_EQ(measured.depth, 12);
  const Outcome as_before = track(dir, 16);  // the old 1/256 scale
  EXPECT_EQ(as_before.no_texture, 60);
  EXPECT_EQ(as_before.tracked, 0);
}

}  // namespace
}  // namespace scale_drift_slam::system
