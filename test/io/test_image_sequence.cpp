// Dataset folders: the TUM, EuRoC and KITTI layouts are recognised and read frame by frame with
// their timestamps and calibrations; a folder of none of them, or a malformed list, is refused
// with the reason; a missing image file gives an empty frame, not an exception.

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "scale_drift_slam/io/image_sequence.h"

namespace scale_drift_slam::io {
namespace {
namespace fs = std::filesystem;

fs::path freshDir(const std::string& name) {
  const fs::path dir = fs::path(SDS_TEST_OUTPUT_DIR) / "image_sequence" / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

void writeImage(const fs::path& path, int value, int width = 8, int height = 6) {
  fs::create_directories(path.parent_path());
  cv::imwrite(path.string(), cv::Mat(height, width, CV_8UC1, cv::Scalar(value)));
}

TEST(ImageSequence, ReadsTumFolders) {
  const fs::path dir = freshDir("tum");
  writeImage(dir / "rgb" / "1.png", 10);
  writeImage(dir / "rgb" / "2.png", 20);
  std::ofstream(dir / "rgb.txt") << "# timestamp filename\n1.5 rgb/1.png\n1.6 rgb/2.png\n"
                                    "1.7 rgb/missing.png\n";
  std::ofstream(dir / "camera.yaml") << "width: 8\nheight: 6\nfx: 5\nfy: 5\ncx: 4\ncy: 3\n";
  const auto sequence = openImageFolder(dir.string());
  EXPECT_EQ(sequence->size(), 3u);
  ASSERT_TRUE(sequence->calibration().has_value());
  EXPECT_EQ(sequence->calibration()->width, 8);
  const auto first = sequence->next();
  ASSERT_TRUE(first.has_value());
  EXPECT_DOUBLE_EQ(first->timestamp, 1.5);
  EXPECT_EQ(first->image.at<unsigned char>(0, 0), 10);
  EXPECT_EQ(sequence->next()->image.at<unsigned char>(0, 0), 20);
  EXPECT_TRUE(sequence->next()->image.empty());
  EXPECT_FALSE(sequence->next().has_value());
}

TEST(ImageSequence, ReadsEurocFolders) {
  const fs::path dir = freshDir("euroc");
  writeImage(dir / "mav0" / "cam0" / "data" / "1403636579763555584.png", 7);
  std::ofstream(dir / "mav0" / "cam0" / "data.csv")
      << "#timestamp [ns],filename\n1403636579763555584,1403636579763555584.png\n";
  std::ofstream(dir / "mav0" / "cam0" / "sensor.yaml")
      << "resolution: [8, 6]\nintrinsics: [5, 5, 4, 3]\ndistortion_model: radial-tangential\n"
         "distortion_coefficients: [0.1, 0.01, 0, 0]\n";
  for (const fs::path& root : {dir, dir / "mav0"}) {
    const auto sequence = openImageFolder(root.string());
    ASSERT_TRUE(sequence->calibration().has_value());
    EXPECT_EQ(sequence->calibration()->distortion.size(), 4u);
    const auto frame = sequence->next();
    EXPECT_NEAR(frame->timestamp, 1403636579.763555584, 1e-6);
    EXPECT_EQ(frame->image.at<unsigned char>(0, 0), 7);
  }
}

TEST(ImageSequence, ReadsKittiFolders) {
  const fs::path dir = freshDir("kitti");
  writeImage(dir / "image_0" / "000000.png", 1, 1241, 376);
  writeImage(dir / "image_0" / "000001.png", 2, 1241, 376);
  std::ofstream(dir / "times.txt") << "0.000000e+00\n1.036400e-01\n";
  std::ofstream(dir / "calib.txt")
      << "P0: 7.18856e+02 0 6.071928e+02 0 0 7.18856e+02 1.852157e+02 0 0 0 1 0\n";
  const auto sequence = openImageFolder(dir.string());
  ASSERT_TRUE(sequence->calibration().has_value());
  EXPECT_DOUBLE_EQ(sequence->calibration()->fx, 718.856);
  EXPECT_EQ(sequence->calibration()->width, 1241);
  sequence->next();
  const auto second = sequence->next();
  EXPECT_NEAR(second->timestamp, 0.10364, 1e-12);
  EXPECT_EQ(second->image.at<unsigned char>(0, 0), 2);
}

TEST(ImageSequence, RefusesUnknownFoldersAndMalformedLists) {
  const fs::path dir = freshDir("unknown");
  EXPECT_THROW(openImageFolder(dir.string()), std::runtime_error);
  EXPECT_THROW(openImageFolder((dir / "nothing").string()), std::runtime_error);
  std::ofstream(dir / "rgb.txt") << "abc rgb/1.png\n";
  try {
    openImageFolder(dir.string());
    ADD_FAILURE() << "accepted a malformed rgb.txt";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("line 1"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace scale_drift_slam::io
