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

void expectListFailure(const std::string& text, ListFormat format, const std::string& reason) {
  try {
    parseFrameList(text, format, "list.txt", "images");
    ADD_FAILURE() << "accepted: " << text;
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("list.txt"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(reason), std::string::npos) << e.what();
  }
}

bool warnedAbout(const FrameList& list, const std::string& words) {
  for (const std::string& warning : list.warnings) {
    if (warning.find(words) != std::string::npos) return true;
  }
  return false;
}

// Issue 17: a `nan` stamp in rgb.txt was accepted and written to the trajectory.
TEST(ImageSequence, NonFiniteStampsAreErrorsNamingTheLine) {
  expectListFailure("1.0 a.png\nnan b.png\n", ListFormat::kTum,
                    "line 2: the timestamp 'nan' is not a finite number");
  expectListFailure("# c\n1.0 a.png\n2.0 b.png\ninf c.png\n", ListFormat::kTum, "line 4");
  expectListFailure("-inf,a.png\n", ListFormat::kEuroc, "line 1: the timestamp '-inf'");
  expectListFailure("1e400 a.png\n", ListFormat::kTum, "line 1");  // overflows to inf
  expectListFailure("0.0\nnan\n", ListFormat::kKittiTimes, "line 2");
  expectListFailure("0.0\n0.1 0.2\n", ListFormat::kKittiTimes, "line 2 is not '<seconds>'");
  expectListFailure("1.0\n", ListFormat::kTum, "line 1 is not '<timestamp> <image>'");
  expectListFailure("# only a comment\n", ListFormat::kTum, "lists no images");
  // A stamp nan in KITTI's times.txt used to end the list silently there.
  const fs::path dir = freshDir("kitti_nan");
  writeImage(dir / "image_0" / "000000.png", 1);
  std::ofstream(dir / "times.txt") << "0.0\nnan\n0.2\n";
  EXPECT_THROW(openImageFolder(dir.string()), std::runtime_error);
}

// Issue 17: stamps reversed, duplicated or all equal gave no warning and unsorted or duplicate
// stamps in the output.
TEST(ImageSequence, ReversedDuplicatedAndEqualStampsAreSortedAndReported) {
  const FrameList reversed =
      parseFrameList("3 c.png\n2 b.png\n1 a.png\n", ListFormat::kTum, "rgb.txt", "dir");
  ASSERT_EQ(reversed.frames.size(), 3u);
  EXPECT_EQ(reversed.frames[0], std::make_pair(1.0, std::string("dir/a.png")));
  EXPECT_EQ(reversed.frames[2], std::make_pair(3.0, std::string("dir/c.png")));
  EXPECT_TRUE(warnedAbout(reversed, "2 timestamp(s) go back in time (first at line 2)"));

  const FrameList duplicated = parseFrameList(
      "1,a.png\n2000000000,b.png\n2000000000,c.png\n"
      "3000000000,d.png\n",
      ListFormat::kEuroc, "data.csv", "dir");
  ASSERT_EQ(duplicated.frames.size(), 3u);
  EXPECT_EQ(duplicated.frames[1].second, "dir/b.png");  // the first of the stamp is kept
  EXPECT_EQ(duplicated.frames[2].second, "dir/d.png");
  EXPECT_TRUE(warnedAbout(duplicated, "1 frame(s) repeat an earlier timestamp (first at line 3)"));

  const FrameList equal =
      parseFrameList("5 a.png\n5 b.png\n5 c.png\n", ListFormat::kTum, "rgb.txt", "dir");
  ASSERT_EQ(equal.frames.size(), 1u);
  EXPECT_EQ(equal.frames[0].second, "dir/a.png");
  EXPECT_TRUE(warnedAbout(equal, "all 3 timestamps are equal"));

  const FrameList ordered = parseFrameList("1 a.png\n2 b.png\n", ListFormat::kTum, "rgb.txt", "");
  EXPECT_TRUE(ordered.warnings.empty());

  // Through a folder: the sequence hands the warnings on and reads in stamp order.
  const fs::path dir = freshDir("tum_reversed");
  writeImage(dir / "rgb" / "1.png", 10);
  writeImage(dir / "rgb" / "2.png", 20);
  std::ofstream(dir / "rgb.txt") << "2.0 rgb/2.png\n1.0 rgb/1.png\n1.0 rgb/2.png\n";
  const auto sequence = openImageFolder(dir.string());
  EXPECT_EQ(sequence->size(), 2u);
  EXPECT_EQ(sequence->warnings().size(), 2u);
  EXPECT_EQ(sequence->next()->image.at<unsigned char>(0, 0), 10);
  EXPECT_EQ(sequence->next()->image.at<unsigned char>(0, 0), 20);
}

}  // namespace
}  // namespace scale_drift_slam::io
