// evaluate_trajectory: scores an estimated trajectory against ground truth (ATE after Sim(3) or
// SE(3) alignment, RPE over fixed distances, scale drift per segment, frames tracked).

#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "scale_drift_slam/evaluation/evaluation_report.h"
#include "scale_drift_slam/io/command_line.h"
#include "scale_drift_slam/io/trajectory_io.h"

namespace sds = scale_drift_slam;

namespace {

const char* kUsage =
    "usage: evaluate_trajectory GROUNDTRUTH ESTIMATE [--align sim3|se3] [--json] [--plot FILE]\n"
    "                           [--out DIR] [--max-dt S] [--rpe-distances D1,D2,..] [--segments "
    "N]\n"
    "Scores an estimated trajectory against ground truth. Both files are TUM format\n"
    "('t tx ty tz qx qy qz qw', camera pose in the world) or EuRoC csv ('t_ns, px, py, pz, qw,\n"
    "qx, qy, qz, ...'). Poses are associated by timestamp, the estimate is aligned by Umeyama\n"
    "(Sim(3) by default, SE(3) with --align se3), then reported: ATE (rmse, mean, median, max),\n"
    "RPE over fixed distances along the true path, the scale per segment after aligning the\n"
    "first segment, and the number of frames tracked out of all ground-truth frames.\n"
    "  --json               print the results as JSON instead of the summary\n"
    "  --out DIR            write DIR/evaluation.json (and DIR/evaluation.png)\n"
    "  --plot FILE          write a PNG: top view and error over time\n"
    "  --max-dt S           association tolerance in seconds (default 0.02)\n"
    "  --rpe-distances LIST metres along the true path (default 1,2,5,10)\n"
    "  --segments N         segments for the scale drift (default 10)\n"
    "  --alignment-from FILE  apply the alignment of an earlier evaluation (its evaluation.json\n"
    "                       or --json output) instead of estimating one: a second run in the\n"
    "                       same map scored in the first run's frame\n";

std::vector<double> parseList(const std::string& text) {
  std::vector<double> values;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) {
    char* end = nullptr;
    const double value = std::strtod(item.c_str(), &end);
    if (item.empty() || *end != '\0') {
      throw std::invalid_argument("--rpe-distances expects numbers separated by commas, got '" +
                                  text + "'");
    }
    values.push_back(value);
  }
  return values;
}

std::vector<sds::io::StampedPose> load(const std::string& path, const std::string& what) {
  std::vector<sds::io::StampedPose> poses = sds::io::loadTrajectory(path);
  if (poses.empty()) throw std::runtime_error(what + " '" + path + "' holds no poses");
  return poses;
}

int run(const sds::io::CommandLine& cl) {
  cl.rejectUnknownFlags(
      {"align", "json", "plot", "out", "max-dt", "rpe-distances", "segments", "alignment-from"});
  if (cl.positional().size() > 2) {
    throw std::invalid_argument("unexpected argument '" + cl.positional()[2] + "'");
  }
  const std::string truth_path = cl.positional(0, "GROUNDTRUTH");
  const std::string estimate_path = cl.positional(1, "ESTIMATE");
  sds::evaluation::EvaluationParams params;
  params.alignment = sds::evaluation::parseAlignmentMode(cl.text("align", "sim3"));
  params.max_time_difference = cl.number("max-dt", params.max_time_difference);
  if (const auto list = cl.value("rpe-distances")) params.rpe_distances = parseList(*list);
  params.scale_segments = static_cast<int>(cl.integer("segments", params.scale_segments));
  params.validate();
  if (const auto from = cl.value("alignment-from")) {
    std::ifstream file(*from);
    if (!file) throw std::runtime_error("cannot read '" + *from + "'");
    try {
      params.given_alignment = sds::evaluation::alignmentFromJson(nlohmann::json::parse(file));
    } catch (const std::exception& e) {
      throw std::runtime_error("'" + *from + "': " + e.what());
    }
  }

  const auto evaluation = sds::evaluation::evaluateTrajectory(
      load(truth_path, "ground truth"), load(estimate_path, "estimate"), params);
  nlohmann::json json = sds::evaluation::toJson(evaluation);
  json["ground_truth_file"] = truth_path;
  json["estimate_file"] = estimate_path;
  if (const auto from = cl.value("alignment-from")) json["alignment_from"] = *from;
  if (const auto out = cl.value("out")) {
    std::error_code error;
    std::filesystem::create_directories(*out, error);
    std::ofstream file(*out + "/evaluation.json");
    if (error || !file) throw std::runtime_error("cannot write '" + *out + "/evaluation.json'");
    file << json.dump(2) << "\n";
    sds::evaluation::saveEvaluationPlot(*out + "/evaluation.png", evaluation);
  }
  if (const auto plot = cl.value("plot")) sds::evaluation::saveEvaluationPlot(*plot, evaluation);
  if (cl.has("json")) {
    std::cout << json.dump(2) << "\n";
  } else {
    if (const auto from = cl.value("alignment-from")) {
      std::cout << "alignment given     from " << *from << " (not estimated)\n";
    }
    std::cout << sds::evaluation::summaryText(evaluation);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return sds::io::runTool(argc, argv, kUsage, {"json"}, run);
}
