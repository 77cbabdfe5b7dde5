// The whole SLAM through run_sequence, as a user runs it, on rendered 640x480 sequences with 1
// grey level of noise: per-frame tracking time (wall and CPU of the tracking thread, median and
// 95th percentile), the per-stage breakdown, the window BA beside it, peak memory, start-up time,
// accuracy (ATE after Sim(3) alignment, % of the path) and, for courtyard_loop, the scale drift
// over the loop. Sequences are rendered once into <bench json dir>/sequences/ and reused.
// courtyard_loop is also rendered at 50 Hz: 1500 frames for the memory figure. The window-BA
// thread is compared with the inline mapper (system.mapping_thread: false) to show that tracking
// does not wait for it.

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "bench_report.h"
#include "scale_drift_slam/evaluation/alignment.h"
#include "scale_drift_slam/io/trajectory_io.h"
#include "scale_drift_slam/sim/sequence.h"
#include "scale_drift_slam/sim/sequence_writer.h"

using namespace scale_drift_slam;
namespace fs = std::filesystem;

namespace {

fs::path renderOnce(const fs::path& root, const std::string& name, const std::string& scene,
                    double rate) {
  const fs::path dir = root / name;
  if (fs::exists(dir / "groundtruth.txt")) return dir;
  sim::SequenceParams params;
  params.scene = scene;
  params.rate = rate;
  params.realism.noise_sigma = 1.0;
  sim::SequenceRenderer renderer(params);
  sim::TumSequenceWriter writer(dir.string(), renderer.calibration(), name);
  for (int k = 0; k < renderer.frameCount(); ++k)
    writer.add(renderer.render(k));
  writer.finish();
  return dir;
}

struct Accuracy {
  double ate_percent = 0.0, scale_drift = 1.0;
};

double segmentScale(const std::vector<Eigen::Vector3d>& estimate,
                    const std::vector<Eigen::Vector3d>& truth, std::size_t begin, std::size_t end) {
  return evaluation::alignSim3({estimate.begin() + begin, estimate.begin() + end},
                               {truth.begin() + begin, truth.begin() + end})
      .scale();
}

Accuracy accuracy(const fs::path& truth_file, const fs::path& estimate_file) {
  std::map<long long, Eigen::Vector3d> truth_by_stamp;
  for (const auto& p : io::loadTrajectory(truth_file.string())) {
    truth_by_stamp[std::llround(p.timestamp * 1e6)] = p.T_world_cam.translation();
  }
  std::vector<Eigen::Vector3d> estimate, truth;
  for (const auto& p : io::loadTrajectory(estimate_file.string())) {
    const auto it = truth_by_stamp.find(std::llround(p.timestamp * 1e6));
    if (it == truth_by_stamp.end()) continue;
    estimate.push_back(p.T_world_cam.translation());
    truth.push_back(it->second);
  }
  const geometry::Sim3 S = evaluation::alignSim3(estimate, truth);
  std::vector<Eigen::Vector3d> aligned;
  for (const auto& p : estimate)
    aligned.push_back(S * p);
  double path = 0.0;
  for (std::size_t i = 1; i < truth.size(); ++i)
    path += (truth[i] - truth[i - 1]).norm();
  // Scale drift: the similarity scale of the last tenth against that of the first tenth.
  const std::size_t n = std::max<std::size_t>(10, truth.size() / 10);
  const double drift = segmentScale(estimate, truth, truth.size() - n, truth.size()) /
                       segmentScale(estimate, truth, 0, n);
  return {100.0 * evaluation::positionRmse(aligned, truth) / path, 1.0 / drift};
}

void runOne(bench::Report& report, const fs::path& tool, const fs::path& sequence,
            const fs::path& out, const std::string& label, const std::string& config) {
  std::string command = "'" + tool.string() + "' '" + sequence.string() + "' --out '" +
                        out.string() + "' --quiet > '" + out.string() + ".log' 2>&1";
  if (!config.empty()) command += " --config '" + config + "'";
  if (std::system(command.c_str()) != 0) {
    report.add(label + ": run_sequence FAILED (see " + out.string() + ".log)", 1, "");
    return;
  }
  nlohmann::json summary;
  std::ifstream(out / "summary.json") >> summary;
  const Accuracy a = accuracy(sequence / "groundtruth.txt", out / "trajectory.txt");
  report.add(label + ": frames tracked", summary["tracked"].get<double>(), "",
             "of " + std::to_string(summary["frames"].get<int>()));
  report.add(label + ": keyframes", summary["keyframes"].get<double>(), "");
  report.add(label + ": ATE (Sim(3)-aligned) / path", a.ate_percent, "%");
  report.add(label + ": scale drift first -> last tenth", a.scale_drift, "");
  for (const std::string stage : {"frame", "tracking_total", "tracking_cpu", "flow", "search",
                                  "motion_ba", "filters", "keyframe", "window_ba"}) {
    if (!summary["timing"].contains(stage)) continue;
    const auto& t = summary["timing"][stage];
    report.add(label + ": " + stage + " median", t["median_ms"].get<double>(), "ms");
    report.add(label + ": " + stage + " p95", t["p95_ms"].get<double>(), "ms");
    if (stage == "frame") report.add(label + ": frame max", t["max_ms"].get<double>(), "ms");
  }
  report.add(label + ": peak memory", summary["peak_memory_mib"].get<double>(), "MiB");
  report.add(label + ": start-up", summary["startup_ms"].get<double>(), "ms");
}

}  // namespace

int main(int argc, char** argv) {
  bench::Report report("tracking", argc, argv);
  const fs::path tool = fs::absolute(fs::path(argv[0])).parent_path() / "run_sequence";
  const fs::path root =
      (argc > 1 ? fs::absolute(fs::path(argv[1])).parent_path() : fs::temp_directory_path()) /
      "sequences";
  fs::create_directories(root);
  const fs::path inline_config = root / "inline_mapper.yaml";
  std::ofstream(inline_config) << "system:\n  mapping_thread: false\n";
  struct Sequence {
    std::string name, scene;
    double rate;
  };
  for (const Sequence& s : {Sequence{"office_orbit", "office_orbit", 0.0},
                            Sequence{"corridor_straight", "corridor_straight", 0.0},
                            Sequence{"courtyard_loop", "courtyard_loop", 0.0},
                            Sequence{"courtyard_loop_1500", "courtyard_loop", 50.0}}) {
    const fs::path sequence = renderOnce(root, s.name, s.scene, s.rate);
    runOne(report, tool, sequence, root / (s.name + "_out"), s.name, "");
  }
  runOne(report, tool, root / "corridor_straight", root / "corridor_inline_out",
         "corridor_straight, mapper inline", inline_config.string());
  return 0;
}
