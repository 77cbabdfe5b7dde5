// The rosbag of a rendered sequence holds the same frames, stamps and poses as its TUM folder,
// and the bag reader gives back images and calibration exactly.

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <tf2_msgs/TFMessage.h>
#include <opencv2/imgcodecs.hpp>

#include "scale_drift_slam/io/trajectory_io.h"
#include "scale_drift_slam/ros/bag_io.h"
#include "scale_drift_slam/sim/sequence.h"
#include "scale_drift_slam/sim/sequence_writer.h"

namespace scale_drift_slam::ros_conversions {
namespace {

void renderBoth(const std::string& directory, const std::string& bag_path, bool color) {
  sim::SequenceParams params;
  params.scene = "office_orbit";
  params.width = 160;
  params.height = 120;
  params.max_frames = 5;
  params.distortion = "radtan";
  params.color = color;
  params.realism.noise_sigma = 2.0;
  sim::SequenceRenderer renderer(params);
  sim::TumSequenceWriter folder(directory, renderer.calibration());
  SequenceBagWriter bag(bag_path, renderer.calibration());
  for (int i = 0; i < renderer.frameCount(); ++i) {  // the loop of render_sequence
    const sim::RenderedFrame frame = renderer.render(i);
    folder.add(frame);
    bag.write(frame.stamp_ns, frame.image, frame.T_world_cam);
  }
}

TEST(BagIo, BagAndFolderHoldTheSameFramesAndStamps) {
  for (const bool color : {false, true}) {
    const std::string directory = ::testing::TempDir() + "/sds_bag_io_" + std::to_string(color);
    const std::string bag_path = directory + ".bag";
    std::filesystem::remove_all(directory);
    renderBoth(directory, bag_path, color);

    const std::vector<BagImage> images = readBagImages(bag_path);
    std::ifstream list(directory + "/rgb.txt");
    std::vector<std::pair<std::string, std::string>> entries;
    for (std::string line; std::getline(list, line);) {
      if (line.empty() || line[0] == '#') continue;
      const size_t space = line.find(' ');
      entries.emplace_back(line.substr(0, space), line.substr(space + 1));
    }
    ASSERT_EQ(images.size(), entries.size());
    ASSERT_EQ(images.size(), 5u);
    const geometry::CameraCalibration folder_calibration = sim::SequenceRenderer([] {
                                                             sim::SequenceParams p;
                                                             p.scene = "office_orbit";
                                                             p.width = 160;
                                                             p.height = 120;
                                                             p.distortion = "radtan";
                                                             return p;
                                                           }())
                                                               .calibration();
    for (size_t i = 0; i < images.size(); ++i) {
      EXPECT_EQ(sim::TumSequenceWriter::formatStamp(images[i].stamp_ns), entries[i].first);
      const cv::Mat png = cv::imread(directory + "/" + entries[i].second, cv::IMREAD_UNCHANGED);
      ASSERT_EQ(png.type(), images[i].image.type());
      EXPECT_EQ(cv::norm(png, images[i].image, cv::NORM_INF), 0.0);
      ASSERT_TRUE(images[i].calibration.has_value());
      EXPECT_EQ(images[i].calibration->distortion, folder_calibration.distortion);
      EXPECT_DOUBLE_EQ(images[i].calibration->fx, folder_calibration.fx);
    }
    const std::vector<io::StampedPose> truth = io::loadTrajectory(directory + "/groundtruth.txt");
    const std::vector<io::StampedPose> bag_truth = readBagPoses(bag_path);
    ASSERT_EQ(truth.size(), bag_truth.size());
    for (size_t i = 0; i < truth.size(); ++i) {
      EXPECT_NEAR(bag_truth[i].timestamp, truth[i].timestamp, 1e-9);
      EXPECT_LT((bag_truth[i].T_world_cam.matrix() - truth[i].T_world_cam.matrix()).norm(), 1e-12);
    }
    // tf carries the same pose at the same stamp.
    rosbag::Bag bag(bag_path, rosbag::bagmode::Read);
    size_t count = 0;
    for (const rosbag::MessageInstance& m : rosbag::View(bag, rosbag::TopicQuery("/tf"))) {
      const auto tf = m.instantiate<tf2_msgs::TFMessage>();
      ASSERT_TRUE(tf);
      ASSERT_EQ(tf->transforms.size(), 1u);
      EXPECT_EQ(tf->transforms[0].header.frame_id, "world");
      EXPECT_EQ(tf->transforms[0].child_frame_id, "camera_ground_truth");
      EXPECT_EQ(sim::TumSequenceWriter::formatStamp(
                    static_cast<std::int64_t>(tf->transforms[0].header.stamp.toNSec())),
                entries[count].first);
      EXPECT_NEAR(tf->transforms[0].transform.translation.x,
                  truth[count].T_world_cam.translation().x(), 1e-12);
      ++count;
    }
    EXPECT_EQ(count, 5u);
    // The streaming reader gives the same images one at a time.
    BagImageReader reader(bag_path);
    EXPECT_EQ(reader.size(), 5u);
    BagImage streamed;
    size_t streamed_count = 0;
    while (reader.next(streamed)) {
      ASSERT_LT(streamed_count, images.size());
      EXPECT_EQ(streamed.stamp_ns, images[streamed_count].stamp_ns);
      EXPECT_EQ(cv::norm(streamed.image, images[streamed_count].image, cv::NORM_INF), 0.0);
      EXPECT_TRUE(streamed.calibration.has_value());
      ++streamed_count;
    }
    EXPECT_EQ(streamed_count, 5u);
  }
}

TEST(BagIo, MissingBagsAndTopicsAreReportedWithTheReason) {
  EXPECT_THROW(readBagImages("/nonexistent/sequence.bag"), std::runtime_error);
  const std::string directory = ::testing::TempDir() + "/sds_bag_io_topics";
  std::filesystem::remove_all(directory);
  renderBoth(directory, directory + ".bag", false);
  try {
    readBagImages(directory + ".bag", "/wrong/topic");
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/wrong/topic"), std::string::npos);
  }
  EXPECT_THROW(SequenceBagWriter("/proc/forbidden.bag", geometry::CameraCalibration()),
               std::runtime_error);
}

}  // namespace
}  // namespace scale_drift_slam::ros_conversions
