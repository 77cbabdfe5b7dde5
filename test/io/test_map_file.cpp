// Map files (io/map_file.h) and restoring a saved map into a new SLAM (SlamSystem::restore): a
// map made by the SLAM on a rendered room sweep is saved, loaded back field by field, refused with
// its reason when the file is bad, and a new run localises in it (without changing it) or extends
// it.

#include <filesystem>
#include <fstream>
#include <iterator>

#include <gtest/gtest.h>

#include "../tracking/synthetic_images.h"
#include "scale_drift_slam/evaluation/alignment.h"
#include "scale_drift_slam/io/map_file.h"
#include "scale_drift_slam/loop/vocabulary.h"
#include "scale_drift_slam/system/slam_system.h"

namespace scale_drift_slam::io {
namespace {

namespace fs = std::filesystem;
constexpr int kWidth = 640, kHeight = 480;
using Kind = MapFileError::Kind;

std::shared_ptr<const geometry::CameraModel> camera() {
  return test::pinholeCamera(450.0);
}

system::SlamParams slamParams() {
  system::SlamParams params;
  params.mapping_thread = false;
  params.loop.recognition.online_training_keyframes = 5;  // a short run: learn the words early
  return params;
}

cv::Mat render(int k) {
  static const auto room = test::boxRoom(4.0, 2.0, 4.0, 40);
  return test::renderPlanes(room, camera()->K(), test::sweepPose(k).inverse(), kWidth, kHeight);
}

/// The first run: frames 0-79 of the sweep, its map and the Sim(3) from its frame to the truth.
struct FirstRun {
  MapFile file;
  geometry::Sim3 S_truth_map;
};

const FirstRun& firstRun() {
  static const FirstRun run = [] {
    system::SlamSystem slam(camera(), slamParams());
    std::vector<Eigen::Vector3d> estimate, truth;
    for (int k = 0; k < 80; ++k) {
      const tracking::FrameResult r =
          slam.processFrame(0.1 * k, render(k), features::PixelEncoding::kMono8);
      if (!r.has_pose) continue;
      estimate.push_back(r.T_cam_world.inverseTranslation());
      truth.push_back(test::sweepPose(k).translation());
    }
    slam.finish();
    FirstRun first;
    first.S_truth_map = evaluation::alignSim3(estimate, truth);
    first.file.calibration = camera()->calibration();
    first.file.params_yaml = "tracker:\n  good_inliers: 50\n";
    first.file.map_version = slam.map().version();
    first.file.snapshot = slam.snapshot();
    // No loop in a sweep: a loop edge by hand, so that the file carries one.
    const auto& keyframes = first.file.snapshot.map.keyframes();
    loop::PoseGraphEdge edge;
    edge.from = keyframes.rbegin()->first;
    edge.to = keyframes.begin()->first;
    edge.S_from_to = geometry::Sim3::fromScale(Eigen::Quaterniond(0.9, 0.1, -0.2, 0.3).normalized(),
                                               Eigen::Vector3d(0.1, -2, 3), 1.25);
    edge.information = loop::Matrix7d::Identity() * 3.5;
    edge.information(0, 6) = edge.information(6, 0) = 0.25;
    edge.kind = loop::EdgeKind::kLoop;
    first.file.snapshot.loop_edges.push_back(edge);
    return first;
  }();
  return run;
}

std::string tempPath(const std::string& name) {
  const fs::path dir = fs::path(SDS_TEST_OUTPUT_DIR) / "map_file";
  fs::create_directories(dir);
  return (dir / name).string();
}

std::string readBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void writeBytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

bool sameMat(const cv::Mat& a, const cv::Mat& b) {
  if (a.rows != b.rows || a.cols != b.cols || a.type() != b.type()) return false;
  return a.empty() || cv::countNonZero(a != b) == 0;
}

void expectSameMap(const map::Map& a, const map::Map& b) {
  ASSERT_EQ(a.numKeyframes(), b.numKeyframes());
  ASSERT_EQ(a.numPoints(), b.numPoints());
  EXPECT_EQ(a.numObservations(), b.numObservations());
  for (const auto& [id, k] : a.keyframes()) {
    ASSERT_TRUE(b.hasKeyframe(id));
    const map::Keyframe& l = b.keyframe(id);
    EXPECT_EQ(k.timestamp, l.timestamp);
    EXPECT_EQ(k.T_kf_world.matrix(), l.T_kf_world.matrix());
    ASSERT_EQ(k.observations.size(), l.observations.size());
    for (std::size_t i = 0; i < k.observations.size(); ++i) {
      EXPECT_EQ(k.observations[i].point_id, l.observations[i].point_id);
      EXPECT_EQ(k.observations[i].xy, l.observations[i].xy);
    }
  }
  for (const auto& [id, p] : a.points()) {
    ASSERT_TRUE(b.hasPoint(id));
    const map::MapPoint& q = b.point(id);
    EXPECT_EQ(p.p_world, q.p_world);
    EXPECT_EQ(p.reference_keyframe, q.reference_keyframe);
    EXPECT_EQ(p.observed_by, q.observed_by);
  }
}

void expectSamePlaces(const std::vector<loop::SavedPlace>& a,
                      const std::vector<loop::SavedPlace>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].id, b[i].id);
    EXPECT_EQ(a[i].timestamp, b[i].timestamp);
    const loop::KeyframeAppearance &x = a[i].appearance, &y = b[i].appearance;
    EXPECT_EQ(x.image_width, y.image_width);
    EXPECT_EQ(x.image_height, y.image_height);
    EXPECT_EQ(x.undistorted, y.undistorted);
    EXPECT_EQ(x.keypoints, y.keypoints);
    EXPECT_EQ(x.octaves, y.octaves);
    EXPECT_TRUE(sameMat(x.descriptors, y.descriptors));
    EXPECT_EQ(a[i].indexed, b[i].indexed);
    EXPECT_EQ(a[i].bow.words, b[i].bow.words);
    EXPECT_EQ(a[i].bow.weights, b[i].bow.weights);
    EXPECT_EQ(a[i].groups.nodes, b[i].groups.nodes);
    EXPECT_EQ(a[i].groups.features, b[i].groups.features);
  }
}

void expectSameFile(const MapFile& a, const MapFile& b) {
  EXPECT_EQ(a.calibration.model, b.calibration.model);
  EXPECT_EQ(a.calibration.describe(), b.calibration.describe());
  EXPECT_EQ(a.calibration.distortion, b.calibration.distortion);
  EXPECT_EQ(a.params_yaml, b.params_yaml);
  EXPECT_EQ(a.map_version, b.map_version);
  const system::MapSnapshot &s = a.snapshot, &t = b.snapshot;
  expectSameMap(s.map, t.map);
  ASSERT_EQ(s.loop_edges.size(), t.loop_edges.size());
  for (std::size_t i = 0; i < s.loop_edges.size(); ++i) {
    EXPECT_EQ(s.loop_edges[i].from, t.loop_edges[i].from);
    EXPECT_EQ(s.loop_edges[i].to, t.loop_edges[i].to);
    EXPECT_EQ(s.loop_edges[i].S_from_to.matrix(), t.loop_edges[i].S_from_to.matrix());
    EXPECT_EQ(s.loop_edges[i].information, t.loop_edges[i].information);
    EXPECT_EQ(s.loop_edges[i].kind, t.loop_edges[i].kind);
  }
  ASSERT_EQ(s.point_appearances.size(), t.point_appearances.size());
  for (const auto& [id, appearance] : s.point_appearances) {
    ASSERT_EQ(t.point_appearances.count(id), 1u);
    const features::PointAppearance& other = t.point_appearances.at(id);
    EXPECT_TRUE(sameMat(appearance.patch(0), other.patch(0)));
    EXPECT_TRUE(sameMat(appearance.patch(1), other.patch(1)));
    EXPECT_EQ(appearance.px_reference, other.px_reference);
  }
  EXPECT_EQ(s.vocabulary, t.vocabulary);
  expectSamePlaces(s.places, t.places);
  EXPECT_EQ(s.keyframe_images, t.keyframe_images);
}

TEST(MapFile, SaveThenLoadGivesBackEveryField) {
  const MapFile& saved = firstRun().file;
  // The run left something in every part of the file.
  ASSERT_GE(saved.snapshot.map.numKeyframes(), 5u);
  ASSERT_FALSE(saved.snapshot.point_appearances.empty());
  ASSERT_FALSE(saved.snapshot.vocabulary.empty());
  ASSERT_EQ(saved.snapshot.places.size(), saved.snapshot.map.numKeyframes());
  ASSERT_EQ(saved.snapshot.keyframe_images.size(), saved.snapshot.map.numKeyframes());
  for (const loop::SavedPlace& place : saved.snapshot.places)
    ASSERT_TRUE(place.indexed && !place.bow.empty()) << place.id;
  const std::string path = tempPath("round_trip.map");
  saveMapFile(path, saved);
  const MapFile loaded = loadMapFile(path);
  expectSameFile(saved, loaded);
  // The vocabulary still parses, the saved bags of words are the vocabulary's, and saving the
  // loaded file again gives the same bytes.
  const loop::Vocabulary vocabulary = loop::Vocabulary::fromBytes(loaded.snapshot.vocabulary, "t");
  EXPECT_GT(vocabulary.numWords(), 0u);
  for (const loop::SavedPlace& place : loaded.snapshot.places) {
    loop::FeatureGroups groups;
    const loop::BowVector bow =
        vocabulary.transform(place.appearance.descriptors, groups,
                             slamParams().loop.recognition.geometry.group_levels_up);
    EXPECT_EQ(bow.words, place.bow.words) << place.id;
    EXPECT_EQ(bow.weights, place.bow.weights) << place.id;
    EXPECT_EQ(groups.features, place.groups.features) << place.id;
  }
  const std::string again = tempPath("round_trip_again.map");
  saveMapFile(again, loaded);
  EXPECT_EQ(readBytes(path), readBytes(again));
}

// The ROS path (doc/map_file.md "In ROS"): the parts the nodes send to the mapping node, joined
// with its map, give the file SlamSystem::snapshot gives; the session every node derives from the
// loaded file is the same and follows the file's content.
TEST(MapFile, PartsSentBetweenTheNodesJoinToTheWholeSnapshot) {
  const system::MapSnapshot& whole = firstRun().file.snapshot;
  system::MapSnapshot tracker_part, loop_part;
  tracker_part.point_appearances = whole.point_appearances;
  loop_part.vocabulary = whole.vocabulary;
  loop_part.places = whole.places;
  loop_part.keyframe_images = whole.keyframe_images;
  // Something of a point and a keyframe the mapper no longer (or not yet) has is left out.
  const map::PointId stray_point = whole.map.points().begin()->first + 1000000;
  tracker_part.point_appearances.emplace(stray_point, whole.point_appearances.begin()->second);
  loop_part.keyframe_images.emplace(999999, std::vector<std::uint8_t>{1, 2, 3});
  MapFile joined = firstRun().file;
  joined.snapshot = system::joinParts(whole.map, whole.loop_edges,
                                      decodeSnapshotPart(encodeSnapshotPart(tracker_part)),
                                      decodeSnapshotPart(encodeSnapshotPart(loop_part)));
  EXPECT_NO_THROW(joined.snapshot.validate());
  expectSameFile(firstRun().file, joined);
  // Bytes that are not a part: a clear error.
  try {
    decodeSnapshotPart("not a part of a map");
    FAIL() << "garbage decoded";
  } catch (const MapFileError& e) {
    EXPECT_EQ(e.kind(), Kind::kMalformed);
  }
}

TEST(MapFile, TheSessionOfALoadedMapIsTheFilesOwn) {
  const std::string path = tempPath("session.map");
  saveMapFile(path, firstRun().file);
  const MapFile a = loadMapFile(path), b = loadMapFile(path);
  EXPECT_NE(mapFileSession(a), 0u);
  EXPECT_EQ(mapFileSession(a), mapFileSession(b));
  MapFile other = firstRun().file;
  other.map_version += 1;
  saveMapFile(path, other);
  EXPECT_NE(mapFileSession(loadMapFile(path)), mapFileSession(a));
}

TEST(MapFile, SavingReplacesTheFileAtOnceAndLeavesNoTemporaryFile) {
  const std::string path = tempPath("atomic.map");
  writeBytes(path, "an older file");
  saveMapFile(path, firstRun().file);
  EXPECT_NO_THROW(loadMapFile(path));
  for (const auto& entry : fs::directory_iterator(fs::path(path).parent_path()))
    EXPECT_EQ(entry.path().string().find(".tmp"), std::string::npos) << entry.path();
  // An unwritable place: a clear error, nothing written.
  try {
    saveMapFile(tempPath("no_such_folder/x.map"), firstRun().file);
    FAIL() << "saved into a missing folder";
  } catch (const MapFileError& e) {
    EXPECT_EQ(e.kind(), Kind::kUnreadable);
    EXPECT_NE(std::string(e.what()).find("cannot write"), std::string::npos) << e.what();
  }
}

/// Loads `bytes` as a map file and returns the error (fails the test when it loads).
MapFileError loadError(const std::string& name, const std::string& bytes) {
  const std::string path = tempPath(name);
  writeBytes(path, bytes);
  try {
    loadMapFile(path);
  } catch (const MapFileError& e) {
    return e;
  }
  ADD_FAILURE() << name << " was loaded";
  return MapFileError(Kind::kUnreadable, "");
}

std::string goodBytes() {
  static const std::string bytes = [] {
    const std::string path = tempPath("good.map");
    saveMapFile(path, firstRun().file);
    return readBytes(path);
  }();
  return bytes;
}

TEST(MapFile, ATruncatedFileIsRefused) {
  const std::string good = goodBytes();
  for (const std::size_t size : {good.size() - 1, good.size() / 2, std::size_t{20}}) {
    const MapFileError e = loadError("truncated.map", good.substr(0, size));
    EXPECT_EQ(e.kind(), Kind::kTruncated) << size << ": " << e.what();
    EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos) << e.what();
  }
}

TEST(MapFile, OneFlippedByteIsACorruption) {
  const std::string good = goodBytes();
  for (const std::size_t at : {std::size_t{40}, good.size() / 3, good.size() - 1}) {
    std::string bad = good;
    bad[at] = static_cast<char>(bad[at] ^ 0x10);
    const MapFileError e = loadError("flipped.map", bad);
    EXPECT_EQ(e.kind(), Kind::kCorrupted) << at << ": " << e.what();
    EXPECT_NE(std::string(e.what()).find("checksum"), std::string::npos) << e.what();
  }
}

TEST(MapFile, AnotherFormatVersionIsRefused) {
  std::string bad = goodBytes();
  bad[8] = static_cast<char>(kMapFileVersion + 1);  // the version, little-endian, after the magic
  const MapFileError e = loadError("version.map", bad);
  EXPECT_EQ(e.kind(), Kind::kOtherVersion) << e.what();
  EXPECT_NE(std::string(e.what()).find("version 2, this build reads version 1"), std::string::npos)
      << e.what();
}

TEST(MapFile, WhatIsNotAMapFileIsRefused) {
  for (const std::string& bytes : {std::string(), std::string("%YAML:1.0\nfx: 450\n"),
                                   std::string(1000, '\0'), goodBytes().substr(1)}) {
    const MapFileError e = loadError("not_a_map.map", bytes);
    EXPECT_EQ(e.kind(), Kind::kNotAMapFile) << e.what();
    EXPECT_NE(std::string(e.what()).find("not a map file"), std::string::npos) << e.what();
  }
  try {
    loadMapFile(tempPath("missing.map"));
    FAIL() << "a missing file was loaded";
  } catch (const MapFileError& e) {
    EXPECT_EQ(e.kind(), Kind::kUnreadable) << e.what();
  }
}

TEST(MapFile, ContentThatDoesNotParseIsRefusedEvenWithARightChecksum) {
  // A right header and checksum over a map that is not consistent: only the content check can
  // tell.
  MapFile broken = firstRun().file;
  broken.snapshot.point_appearances.clear();
  const std::string path = tempPath("inconsistent.map");
  // A point observed by a keyframe the map does not hold: refused by the content check.
  map::MapPoint stray;
  stray.id = 999999;
  stray.reference_keyframe = 4000000;
  broken.snapshot.map.addPoint(stray);
  saveMapFile(path, broken);
  try {
    loadMapFile(path);
    FAIL() << "an inconsistent map was loaded";
  } catch (const MapFileError& e) {
    EXPECT_EQ(e.kind(), Kind::kMalformed) << e.what();
    EXPECT_NE(std::string(e.what()).find("unknown reference keyframe"), std::string::npos)
        << e.what();
  }
}

TEST(MapFile, AMapOfAnotherCameraIsRefused) {
  const MapFile& file = firstRun().file;
  EXPECT_NO_THROW(checkMapCamera(file, camera()->calibration(), "x.map"));
  geometry::CameraCalibration other = camera()->calibration();
  other.fx += 5.0;
  try {
    checkMapCamera(file, other, "x.map");
    FAIL() << "another camera was accepted";
  } catch (const MapFileError& e) {
    EXPECT_EQ(e.kind(), Kind::kOtherCamera);
    EXPECT_NE(std::string(e.what()).find("another camera"), std::string::npos) << e.what();
  }
  other = camera()->calibration();
  other.width = 1280;
  EXPECT_THROW(checkMapCamera(file, other, "x.map"), MapFileError);
}

/// Frames 30-49 of the sweep in a new SLAM that starts in the saved map; returns the worst
/// position error against the truth in the first run's frame (its Sim(3) to the truth, not
/// re-estimated) and the first relocalised frame.
struct SecondRun {
  int first_relocalised = -1;
  int tracked_after = 0, lost_after = 0;
  double worst_error = 0.0;
};

SecondRun runInSavedMap(system::SlamSystem& slam, int first, int last) {
  SecondRun run;
  for (int k = first; k < last; ++k) {
    const tracking::FrameResult r =
        slam.processFrame(20.0 + 0.1 * k, render(k), features::PixelEncoding::kMono8);
    if (run.first_relocalised < 0 && r.relocalised) run.first_relocalised = k;
    if (run.first_relocalised < 0) continue;
    if (!r.has_pose) {
      ++run.lost_after;
      continue;
    }
    ++run.tracked_after;
    const Eigen::Vector3d centre = firstRun().S_truth_map * r.T_cam_world.inverseTranslation();
    run.worst_error = std::max(run.worst_error, (centre - test::sweepPose(k).translation()).norm());
  }
  slam.finish();
  return run;
}

TEST(MapRestore, ANewRunLocalisesInTheSavedMapWithoutChangingIt) {
  const std::string path = tempPath("localise.map");
  saveMapFile(path, firstRun().file);
  MapFile file = loadMapFile(path);
  const map::Map saved_map = file.snapshot.map;
  system::SlamSystem slam(camera(), slamParams());
  slam.restore(std::move(file.snapshot), /*localization_only=*/true);
  EXPECT_EQ(slam.restoredKeyframes(), saved_map.numKeyframes());
  const SecondRun run = runInSavedMap(slam, 30, 50);
  std::printf("relocalised at frame %d (from 30), then %d tracked, %d lost, worst error %.4f m\n",
              run.first_relocalised, run.tracked_after, run.lost_after, run.worst_error);
  ASSERT_GE(run.first_relocalised, 30) << "never relocalised";
  EXPECT_LE(run.first_relocalised, 33);
  EXPECT_EQ(run.lost_after, 0);
  EXPECT_LT(run.worst_error, 0.03);
  // Localisation only: the map is the saved one, unchanged to the bit.
  expectSameMap(saved_map, slam.map());
  EXPECT_EQ(slam.tracker().trackingMap().numKeyframes(), saved_map.numKeyframes());
}

TEST(MapRestore, InMappingModeTheNewSessionExtendsTheSavedMap) {
  MapFile file = firstRun().file;
  const map::Map saved_map = file.snapshot.map;
  const map::KeyframeId last_saved = saved_map.keyframes().rbegin()->first;
  system::SlamSystem slam(camera(), slamParams());
  slam.restore(std::move(file.snapshot), /*localization_only=*/false);
  // Beyond the first run's sweep: new ground, new keyframes in the same frame.
  const SecondRun run = runInSavedMap(slam, 60, 120);
  ASSERT_GE(run.first_relocalised, 60) << "never relocalised";
  EXPECT_LE(run.first_relocalised, 63);
  EXPECT_EQ(run.lost_after, 0);
  EXPECT_LT(run.worst_error, 0.05);
  const map::Map& grown = slam.map();
  ASSERT_GT(grown.numKeyframes(), saved_map.numKeyframes());
  for (const auto& [id, keyframe] : saved_map.keyframes())
    EXPECT_TRUE(grown.hasKeyframe(id)) << id;
  // The new keyframes continue the saved ids and lie where the camera was (first run's frame).
  for (const auto& [id, keyframe] : grown.keyframes()) {
    if (saved_map.hasKeyframe(id)) continue;
    EXPECT_GT(id, last_saved);
    const Eigen::Vector3d centre =
        firstRun().S_truth_map * keyframe.T_kf_world.inverseTranslation();
    const double t = keyframe.timestamp - 20.0;
    const int k = static_cast<int>(std::lround(t / 0.1));
    EXPECT_LT((centre - test::sweepPose(k).translation()).norm(), 0.05) << "keyframe " << id;
  }
}

TEST(MapRestore, ABadMapLeavesTheSystemAsItWas) {
  // An inconsistent snapshot is refused before anything changes: the same system then takes a
  // good one.
  system::SlamSystem slam(camera(), slamParams());
  system::MapSnapshot bad = firstRun().file.snapshot;
  bad.places.front().id = 777777;
  EXPECT_THROW(slam.restore(bad, true), std::invalid_argument);
  EXPECT_EQ(slam.restoredKeyframes(), 0u);
  EXPECT_EQ(slam.tracker().trackingMap().numKeyframes(), 0u);
  // Bad files never reach the system; a good one does, once, and only before the first frame.
  EXPECT_THROW(loadMapFile(tempPath("missing.map")), MapFileError);
  slam.restore(firstRun().file.snapshot, true);
  EXPECT_EQ(slam.restoredKeyframes(), firstRun().file.snapshot.map.numKeyframes());
  slam.processFrame(20.0, render(30), features::PixelEncoding::kMono8);
  EXPECT_THROW(slam.restore(firstRun().file.snapshot, true), std::logic_error);
  slam.finish();
  expectSameMap(firstRun().file.snapshot.map, slam.map());
}

}  // namespace
}  // namespace scale_drift_slam::io
