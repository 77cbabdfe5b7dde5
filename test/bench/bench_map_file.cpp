// Map files (issue 19): saving, loading and restoring a map of 1000 keyframes, and the file size
// per keyframe, in total and by part. The map is synthetic but made of real parts: the keyframe
// images are rendered courtyard_loop frames (JPEG 95, as the loop closer keeps them), their ORB
// features come from the loop closer's extractor and the vocabulary is learned from the first 30
// of them (as online); each keyframe holds 125 new points (patches cut from its image) and 520
// observations, the courtyard run's proportions (97 keyframes, 12115 points, 50529 observations).
// One core. Measures, asserts nothing.

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "bench_report.h"
#include "scale_drift_slam/common/stopwatch.h"
#include "scale_drift_slam/features/image_preparation.h"
#include "scale_drift_slam/io/map_file.h"
#include "scale_drift_slam/loop/appearance.h"
#include "scale_drift_slam/loop/vocabulary.h"
#include "scale_drift_slam/sim/sequence.h"
#include "scale_drift_slam/system/slam_system.h"

namespace {

namespace sds = scale_drift_slam;
namespace fs = std::filesystem;
using sds::bench::Report;

constexpr int kKeyframes = 1000;
constexpr int kDistinctImages = 60;
constexpr int kPointsPerKeyframe = 125;
constexpr int kObservationsPerKeyframe = 520;

struct KeyframeImage {
  std::vector<std::uint8_t> jpeg;
  sds::loop::KeyframeAppearance appearance;
  sds::features::ImagePyramid pyramid;
};

std::vector<KeyframeImage> renderImages(const sds::sim::SequenceParams& params) {
  sds::sim::SequenceRenderer renderer(params);
  sds::loop::AppearanceExtractor extractor{sds::loop::AppearanceParams{}};
  std::vector<KeyframeImage> images;
  for (int i = 0; i < kDistinctImages; ++i) {
    const cv::Mat image = renderer.render(i * renderer.frameCount() / kDistinctImages).image;
    KeyframeImage k;
    cv::imencode(".jpg", image, k.jpeg, {cv::IMWRITE_JPEG_QUALITY, 95});
    k.appearance = extractor.extract(image, &renderer.camera());
    k.pyramid = sds::features::buildPyramid(image, 2);
    images.push_back(std::move(k));
  }
  return images;
}

/// Keyframe k, its points and observations of its own and the previous keyframes' points.
void addKeyframe(int k, const KeyframeImage& image, std::mt19937& rng,
                 sds::system::MapSnapshot& s) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_real_distribution<double> pixel(30.0, 600.0);
  const auto id = static_cast<sds::map::KeyframeId>(k);
  for (int p = 0; p < kPointsPerKeyframe; ++p) {
    sds::map::MapPoint point;
    point.id = static_cast<sds::map::PointId>(k * kPointsPerKeyframe + p);
    point.p_world = Eigen::Vector3d(unit(rng), unit(rng), unit(rng)) * 10.0;
    point.reference_keyframe = id;
    s.map.addPoint(point);
    sds::features::PointAppearance appearance;
    appearance.cut(image.pyramid, Eigen::Vector2d(pixel(rng), pixel(rng) * 0.75));
    s.point_appearances.emplace(point.id, std::move(appearance));
  }
  sds::map::Keyframe keyframe;
  keyframe.id = id;
  keyframe.timestamp = 1000.0 + k / 30.0;
  keyframe.T_kf_world = sds::geometry::SE3(
      Eigen::Quaterniond(1.0, 0.01 * unit(rng), 0.01 * unit(rng), 0.01 * unit(rng)).normalized(),
      Eigen::Vector3d(0.1 * k, unit(rng), unit(rng)));
  const int oldest = std::max(0, (k - 4) * kPointsPerKeyframe);
  const int newest = (k + 1) * kPointsPerKeyframe;
  std::uniform_int_distribution<int> any_point(oldest, newest - 1);
  std::vector<bool> used(newest - oldest, false);
  while (static_cast<int>(keyframe.observations.size()) <
         std::min(kObservationsPerKeyframe, newest - oldest)) {
    const int p = any_point(rng);
    if (used[p - oldest]) continue;
    used[p - oldest] = true;
    keyframe.observations.push_back(
        {static_cast<sds::map::PointId>(p), Eigen::Vector2d(0.5 * unit(rng), 0.4 * unit(rng))});
  }
  s.map.addKeyframe(std::move(keyframe));
  s.places.push_back({id, 1000.0 + k / 30.0, image.appearance});
  s.keyframe_images.emplace(id, image.jpeg);
}

sds::io::MapFile syntheticMap(const sds::sim::SequenceParams& params,
                              const std::vector<KeyframeImage>& images) {
  sds::io::MapFile file;
  file.calibration = sds::sim::SequenceRenderer(params).calibration();
  file.params_yaml = "(default parameters)\n";
  std::mt19937 rng(1);
  for (int k = 0; k < kKeyframes; ++k)
    addKeyframe(k, images[static_cast<std::size_t>(k % kDistinctImages)], rng, file.snapshot);
  std::vector<cv::Mat> descriptors;
  for (int k = 0; k < 30; ++k)
    descriptors.push_back(images[static_cast<std::size_t>(k)].appearance.descriptors);
  const sds::loop::Vocabulary vocabulary =
      sds::loop::Vocabulary::train(descriptors, sds::loop::VocabularyParams{});
  file.snapshot.vocabulary = vocabulary.toBytes();
  // Every keyframe indexed, as in a map saved after the vocabulary was learned.
  const int levels_up = sds::loop::PlaceRecognitionParams{}.geometry.group_levels_up;
  for (sds::loop::SavedPlace& place : file.snapshot.places) {
    place.indexed = true;
    place.bow = vocabulary.transform(place.appearance.descriptors, place.groups, levels_up);
  }
  for (int k = 5; k + 90 < kKeyframes; k += 100) {  // ten loops
    sds::loop::PoseGraphEdge edge;
    edge.from = static_cast<sds::map::KeyframeId>(k + 90);
    edge.to = static_cast<sds::map::KeyframeId>(k);
    edge.kind = sds::loop::EdgeKind::kLoop;
    file.snapshot.loop_edges.push_back(edge);
  }
  file.map_version = file.snapshot.map.version();
  return file;
}

double fileKiB(const std::string& path) {
  return static_cast<double>(fs::file_size(path)) / 1024.0;
}

/// The file's bytes per keyframe taken by one part: the size without it, subtracted.
void reportParts(Report& report, const sds::io::MapFile& file, const std::string& dir,
                 double total_kib) {
  const auto without = [&](const std::string& part, auto strip) {
    sds::io::MapFile smaller = file;
    strip(smaller.snapshot);
    const std::string path = dir + "/without_" + part + ".map";
    sds::io::saveMapFile(path, smaller);
    report.add("  of which " + part + " per keyframe", (total_kib - fileKiB(path)) / kKeyframes,
               "KiB");
  };
  without("keyframe images (JPEG 95)", [](auto& s) { s.keyframe_images.clear(); });
  without("place recognition (ORB features)", [](auto& s) { s.places.clear(); });
  without("point appearances (patches)", [](auto& s) { s.point_appearances.clear(); });
}

}  // namespace

int main(int argc, char** argv) {
  Report report("map_file", argc, argv);
  sds::sim::SequenceParams params;
  params.scene = "courtyard_loop";
  params.realism.noise_sigma = 1.0;
  const std::vector<KeyframeImage> images = renderImages(params);
  const sds::io::MapFile file = syntheticMap(params, images);
  const std::string dir = (fs::temp_directory_path() / "sds_bench_map_file").string();
  fs::create_directories(dir);
  const std::string path = dir + "/map_1000.map";
  const auto& s = file.snapshot;
  std::printf("synthetic map: %zu keyframes, %zu points, %zu observations, %zu loop edges\n",
              s.map.numKeyframes(), s.map.numPoints(), s.map.numObservations(),
              s.loop_edges.size());

  report.timeMs("save 1000 keyframes (serialise, write, rename)", 5,
                [&] { sds::io::saveMapFile(path, file); });
  const double kib = fileKiB(path);
  report.add("file size", kib / 1024.0, "MiB");
  report.add("file size per keyframe", kib / kKeyframes, "KiB");
  reportParts(report, file, dir, kib);
  sds::io::MapFile loaded;
  report.timeMs("load 1000 keyframes (read, checksum, parse, check)", 5,
                [&] { loaded = sds::io::loadMapFile(path); });
  const std::shared_ptr<const sds::geometry::CameraModel> camera =
      sds::geometry::makeCameraModel(file.calibration);
  sds::system::SlamParams slam_params;
  slam_params.mapping_thread = false;
  // Restoring, and loading then restoring, timed by hand: the copy of the snapshot before and the
  // teardown of the SLAM after (freeing ~0.5 GB of small objects) are left out.
  std::vector<double> restore_ms, both_ms;
  for (int r = 0; r < 3; ++r) {
    sds::system::MapSnapshot copy = loaded.snapshot;
    {
      sds::system::SlamSystem slam(camera, slam_params);
      const sds::common::Stopwatch timer;
      slam.restore(std::move(copy), true);
      restore_ms.push_back(timer.ms());
    }
    sds::system::SlamSystem slam(camera, slam_params);
    const sds::common::Stopwatch timer;
    slam.restore(sds::io::loadMapFile(path).snapshot, true);
    both_ms.push_back(timer.ms());
  }
  std::sort(restore_ms.begin(), restore_ms.end());
  std::sort(both_ms.begin(), both_ms.end());
  report.add("restore 1000 keyframes into a new SLAM (bags of words, tracking map)", restore_ms[1],
             "ms", "median of 3, min " + std::to_string(restore_ms[0]));
  report.add("load and restore, together", both_ms[1], "ms",
             "median of 3, min " + std::to_string(both_ms[0]));
  fs::remove_all(dir);
  return 0;
}
