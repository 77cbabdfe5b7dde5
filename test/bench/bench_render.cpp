// Rendering speed: frames per second of the renderer alone (one core) per scene at its default
// image size (640x480; the city_* driving scenes 1241x376) and lens model, the scene build time,
// and a whole 600-frame sequence written as a TUM folder.

#include <chrono>
#include <ctime>
#include <filesystem>
#include <string>

#include "bench_report.h"
#include "scale_drift_slam/sim/renderer.h"
#include "scale_drift_slam/sim/scenario.h"
#include "scale_drift_slam/sim/sequence.h"
#include "scale_drift_slam/sim/sequence_writer.h"

namespace sds = scale_drift_slam;

int main(int argc, char** argv) {
  sds::bench::Report report("render", argc, argv);
  for (const std::string& name : sds::sim::scenarioNames()) {
    std::unique_ptr<sds::sim::Scenario> scenario;
    report.timeMs(name + ": build scene (textures)", 1, [&] {
      scenario = std::make_unique<sds::sim::Scenario>(sds::sim::makeScenario(name, 1));
    });
    for (const std::string distortion : {"none", "radtan", "fisheye"}) {
      sds::sim::SequenceParams params;
      params.distortion = distortion;
      const Eigen::Vector2i size = sds::sim::defaultImageSize(name);
      params.width = size.x();
      params.height = size.y();
      const std::string label =
          name + " " + std::to_string(size.x()) + "x" + std::to_string(size.y()) + " ";
      const auto camera = sds::geometry::makeCameraModel(
          sds::sim::sequenceCalibration(params, scenario->horizontal_fov_deg));
      sds::sim::Renderer renderer(*camera);
      cv::Mat image;
      const int frames = 200;
      const auto start = std::chrono::steady_clock::now();
      const std::clock_t cpu_start = std::clock();
      for (int i = 0; i < frames; ++i) {
        const double t = scenario->duration * i / frames;
        renderer.render(scenario->scene, scenario->T_world_cam(t).inverse(), image);
      }
      const double seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      const double cpu_seconds = static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;
      report.add(label + distortion + ": renderer, wall clock", frames / seconds, "fps",
                 std::to_string(frames) + " frames spread over the trajectory");
      report.add(label + distortion + ": renderer, CPU time", frames / cpu_seconds, "fps",
                 "one thread; on a shared machine wall-clock fps is lower");
    }
  }
  // Traffic (render_sequence --traffic): the moving cars' surfaces are moved before each frame.
  for (const std::string name : {"city_block", "city_loop"}) {
    std::unique_ptr<sds::sim::Scenario> scenario;
    sds::sim::ScenarioOptions options;
    options.traffic = true;
    report.timeMs(name + " --traffic: build scene (textures, traffic)", 1, [&] {
      scenario = std::make_unique<sds::sim::Scenario>(sds::sim::makeScenario(name, 1, options));
    });
    sds::sim::SequenceParams params;
    params.width = 1241;
    params.height = 376;
    const auto camera = sds::geometry::makeCameraModel(
        sds::sim::sequenceCalibration(params, scenario->horizontal_fov_deg));
    sds::sim::Renderer renderer(*camera);
    cv::Mat image;
    const int frames = 200;
    const std::clock_t cpu_start = std::clock();
    for (int i = 0; i < frames; ++i) {
      const double t = scenario->duration * i / frames;
      scenario->animate(t, scenario->scene);
      renderer.render(scenario->scene, scenario->T_world_cam(t).inverse(), image);
    }
    const double cpu_seconds = static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;
    report.add(name + " --traffic 1241x376 none: renderer, CPU time", frames / cpu_seconds, "fps",
               "one thread, moving cars placed per frame");
  }
  const std::string out = std::filesystem::temp_directory_path() / "sds_bench_render";
  std::filesystem::remove_all(out);
  report.timeMs(
      "office_orbit: 600 frames 640x480 to a TUM folder (PNG)", 1,
      [&] {
        sds::sim::SequenceParams params;
        params.scene = "office_orbit";
        sds::sim::SequenceRenderer renderer(params);
        sds::sim::TumSequenceWriter writer(out, renderer.calibration());
        for (int i = 0; i < renderer.frameCount(); ++i)
          writer.add(renderer.render(i));
      },
      "scene build, rendering, optics blur, PNG writing");
  std::filesystem::remove_all(out);
  return 0;
}
