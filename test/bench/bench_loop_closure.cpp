// Loop-closure speed (issue 7): the whole correction of a 1000-keyframe loop by the mapper
// (essential pose graph in Sim(3) and SE(3), point correction, structure-only BA over every point)
// on a synthetic drifted map, and the metric verification of a candidate (depth regression, P3P
// RANSAC, warped-patch search, scale) on rendered 640x480 views. Place-recognition queries are
// measured by bench_place_recognition. One core. Measures, asserts nothing.

#include <cstdio>
#include <string>

#include "../tracking/synthetic_images.h"
#include "bench_report.h"
#include "scale_drift_slam/geometry/so3.h"
#include "scale_drift_slam/loop/loop_verification.h"
#include "scale_drift_slam/mapping/mapper.h"
#include "scale_drift_slam/sim/drifting_pose_graph.h"

namespace {

namespace sds = scale_drift_slam;
using sds::bench::Report;

constexpr int kKeyframes = 1000;
constexpr int kNewPointsPerKeyframe = 25;
constexpr int kViewsPerPoint = 10;  // consecutive keyframes: ~6 essential-graph edges each

/// A mapper holding a drifted circle of keyframes (sim/drifting_pose_graph.h) whose points are
/// placed where the drifted poses and local scales put them, and the true loop constraint.
sds::mapping::Mapper driftedMapper(sds::loop::PoseGraphMode mode, sds::loop::LoopConstraint* loop) {
  sds::sim::DriftingPoseGraphOptions options;
  options.keyframes_per_lap = kKeyframes;
  options.log_scale_drift_per_keyframe = 0.0005;
  options.rotation_noise = 2e-4;
  options.translation_noise = 2e-4;
  const sds::sim::DriftingPoseGraph truth = sds::sim::makeDriftingPoseGraph(options);
  sds::mapping::MapperParams params;
  params.run_window_ba = false;
  params.loop_correction.graph.mode = mode;
  sds::mapping::Mapper mapper(params, 450.0);
  std::vector<std::vector<sds::map::Observation>> observations(kKeyframes);
  std::vector<sds::map::NewMapPoint> points;
  sds::map::PointId next = 0;
  for (int i = 0; i < kKeyframes; ++i) {
    const sds::geometry::SE3 T_world_true = truth.T_kf_world_true[i].inverse();
    for (int k = 0; k < kNewPointsPerKeyframe; ++k) {
      const Eigen::Vector3d in_camera(-1.5 + 0.12 * k, 0.4 * std::sin(k), 2.0 + 0.04 * k);
      const Eigen::Vector3d p_true = T_world_true * in_camera;
      const double s = truth.S_kf_world_true[i].scale();
      points.push_back({next, truth.T_kf_world_estimate[i].inverse() * (s * in_camera),
                        static_cast<sds::map::KeyframeId>(i)});
      for (int j = i; j < std::min(kKeyframes, i + kViewsPerPoint); ++j) {
        const Eigen::Vector3d seen = truth.T_kf_world_true[j] * p_true;
        if (seen.z() > 0.1) observations[j].push_back({next, seen.head<2>() / seen.z()});
      }
      ++next;
    }
  }
  std::size_t point = 0;
  for (int i = 0; i < kKeyframes; ++i) {
    sds::map::KeyframeMessage message;
    message.keyframe.id = static_cast<sds::map::KeyframeId>(i);
    message.keyframe.T_kf_world = truth.T_kf_world_estimate[i];
    message.keyframe.observations = observations[i];
    for (int k = 0; k < kNewPointsPerKeyframe; ++k)
      message.new_points.push_back(points[point++]);
    mapper.addKeyframe(message);
  }
  const auto& V = truth.S_kf_world_true;
  loop->current_id = kKeyframes - 1;
  loop->loop_id = 0;
  loop->S_current_loop = V.back() * V.front().inverse();
  loop->scale = loop->S_current_loop.scale();
  return mapper;
}

void benchCorrection(Report& report) {
  for (auto mode : {sds::loop::PoseGraphMode::kSim3, sds::loop::PoseGraphMode::kSE3}) {
    sds::loop::LoopConstraint loop;
    const sds::mapping::Mapper drifted = driftedMapper(mode, &loop);
    const std::string name = "1000-keyframe loop, " + sds::loop::toString(mode);
    sds::mapping::LoopCorrectionStatistics stats;
    report.timeMs(name + ": whole correction", 5, [&] {
      sds::mapping::Mapper mapper = drifted;  // the copy is not timed below
      mapper.closeLoop(loop, &stats);
    });
    std::printf("  %s\n", stats.describe().c_str());
    report.add(name + ": build the graph", stats.build_ms, "ms");
    report.add(name + ": solve the graph", stats.graph_ms, "ms",
               std::to_string(stats.graph_iterations) + " LM iterations, " +
                   std::to_string(stats.covisibility_edges) + " co-visibility edges");
    report.add(name + ": move keyframes and points", stats.correction_ms, "ms");
    report.add(name + ": structure-only BA", stats.structure_ms, "ms",
               std::to_string(drifted.map().numPoints()) + " points, " +
                   std::to_string(drifted.map().numObservations()) + " observations");
    report.add(name + ": total (mapper's own clock)", stats.total_ms, "ms");
  }
}

void benchVerification(Report& report) {
  sds::geometry::CameraCalibration c;
  c.fx = c.fy = 450.0;
  c.cx = 319.5;
  c.cy = 239.5;
  c.width = 640;
  c.height = 480;
  const auto camera = sds::geometry::makeCameraModel(c);
  const auto room = sds::test::boxRoom(4.0, 2.0, 4.0, 40);
  const sds::geometry::SE3 T_loop;
  const sds::geometry::SE3 T_current(sds::geometry::expSO3(Eigen::Vector3d(0.02, 0.14, -0.03)),
                                     Eigen::Vector3d(-0.35, 0.1, -0.3));
  sds::loop::AppearanceExtractor extractor{sds::loop::AppearanceParams{}};
  struct Side {
    cv::Mat image;
    sds::loop::KeyframeAppearance features;
    sds::loop::VerificationView view;
  } sides[2];
  const sds::geometry::SE3 poses[2] = {T_current, T_loop};
  for (int s = 0; s < 2; ++s) {
    sides[s].image = sds::test::renderPlanes(room, camera->K(), poses[s], 640, 480);
    sides[s].features = extractor.extract(sides[s].image, camera.get());
    sides[s].view.features = &sides[s].features;
    sides[s].view.image = sds::features::buildPyramid(sides[s].image, 2);
    for (int k = 0; k < 250; ++k) {  // a grid of wall points, as a keyframe's map points
      const Eigen::Vector3d p_cam =
          poses[s] * Eigen::Vector3d(-3.5 + 0.28 * (k % 25), -1.6 + 0.32 * (k / 25), 4.0);
      const auto px = camera->project(p_cam);
      if (!px || !camera->isInImage(*px, 20.0)) continue;
      sides[s].view.point_ids.push_back(static_cast<sds::map::PointId>(k));
      sides[s].view.point_xy.push_back(p_cam.head<2>() / p_cam.z());
      sides[s].view.point_camera.push_back(p_cam);
    }
  }
  const sds::loop::PlaceRecognitionParams recognition;
  const auto matches =
      sds::loop::checkGeometry(
          sides[0].features, sides[1].features,
          sds::loop::matchDescriptors(sides[0].features, sides[1].features, recognition.geometry),
          recognition.geometry)
          .inlier_matches;
  sds::loop::LoopVerification result;
  report.timeMs("loop verification (640x480, 250 map points each)", 20, [&] {
    result = sds::loop::verifyLoop(sides[0].view, sides[1].view, matches, *camera,
                                   sds::loop::LoopVerificationParams{});
  });
  report.add("loop verification: final inliers", result.constraint.num_inliers, "",
             result.success ? "verified" : "refused: " + result.reason);
}

}  // namespace

int main(int argc, char** argv) {
  try {
    cv::setNumThreads(1);
    Report report("loop_closure", argc, argv);
    benchVerification(report);
    benchCorrection(report);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_loop_closure: %s\n", e.what());
    return 1;
  }
  return 0;
}
