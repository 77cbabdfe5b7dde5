#pragma once
// The file parsers as fuzz targets (issue 17), shared by the gtest fuzz test (a short seeded run
// in ctest, test/io/test_parser_fuzz.cpp) and the longer benchmark (scripts/bench fuzz,
// test/bench/bench_fuzz.cpp). Each target parses one mutated input and judges the outcome:
//   - refused: only with a std::runtime_error of the parser's own (its prefix names the file),
//     never another exception type or a raw yaml-cpp message;
//   - accepted: every number finite and the result passing the same validation as a good file
//     (a calibration projects a point to a finite pixel, the parameters validate and print
//     without nan or inf, a frame list is finite and strictly increasing).
// No gtest here: a target returns what went wrong as text, "" when the outcome is fine.

#include <chrono>
#include <cmath>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "../common/fuzz_mutator.h"
#include "scale_drift_slam/geometry/camera_model.h"
#include "scale_drift_slam/io/calibration_io.h"
#include "scale_drift_slam/io/image_sequence.h"
#include "scale_drift_slam/io/place_recognition_params_io.h"
#include "scale_drift_slam/io/slam_params_io.h"

namespace scale_drift_slam::testing {

struct FuzzVerdict {
  bool accepted = false;
  std::string problem;  ///< "" when the outcome is acceptable.
};

/// Runs `parse`; a refusal must be a std::runtime_error starting with one of `prefixes`.
template <typename Parse, typename Check>
FuzzVerdict judge(Parse parse, Check check, const std::vector<std::string>& prefixes) {
  FuzzVerdict verdict;
  try {
    verdict.problem = check(parse());
    verdict.accepted = true;
  } catch (const std::runtime_error& e) {
    const std::string message = e.what();
    bool ours = false;
    for (const std::string& prefix : prefixes)
      ours = ours || message.rfind(prefix, 0) == 0;
    if (!ours) verdict.problem = "refused without naming the file: " + message;
  } catch (const std::exception& e) {
    verdict.problem = std::string("unexpected exception type: ") + e.what();
  }
  return verdict;
}

inline std::string checkCalibration(const geometry::CameraCalibration& c) {
  try {
    c.validate();
  } catch (const std::exception& e) {
    return std::string("accepted an invalid calibration: ") + e.what();
  }
  if (!std::isfinite(c.fx) || !std::isfinite(c.fy) || !std::isfinite(c.cx) ||
      !std::isfinite(c.cy)) {
    return "accepted a non-finite calibration: " + c.describe();
  }
  const auto pixel = geometry::makeCameraModel(c)->project(Eigen::Vector3d(0.01, -0.01, 1.0));
  if (pixel && !pixel->allFinite()) return "projects to a non-finite pixel: " + c.describe();
  return "";
}

inline std::string checkSlamParams(const system::SlamParams& params) {
  try {
    params.validate();
  } catch (const std::exception& e) {
    return std::string("accepted invalid parameters: ") + e.what();
  }
  std::string printed = io::formatSlamParams(params);
  for (char& c : printed)
    c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (printed.find("nan") != std::string::npos || printed.find("inf") != std::string::npos) {
    return "accepted a non-finite parameter:\n" + printed;
  }
  return "";
}

inline std::string checkPlaceRecognitionParams(const loop::PlaceRecognitionParams& p) {
  try {
    p.validate();
  } catch (const std::exception& e) {
    return std::string("accepted invalid parameters: ") + e.what();
  }
  const double values[] = {p.appearance.scale_factor,      p.geometry.ratio,
                           p.geometry.ransac_threshold_px, p.geometry.ransac_confidence,
                           p.geometry.min_inlier_ratio,    p.geometry.min_coverage,
                           p.geometry.max_scale_change,    p.recent_seconds_excluded,
                           p.min_reference_score,          p.min_normalized_score};
  for (const double value : values) {
    if (!std::isfinite(value)) return "accepted a non-finite place recognition parameter";
  }
  return "";
}

inline std::string checkFrameList(const io::FrameList& list) {
  if (list.frames.empty()) return "accepted an empty list";
  for (std::size_t i = 0; i < list.frames.size(); ++i) {
    if (!std::isfinite(list.frames[i].first)) return "accepted a non-finite stamp";
    if (i > 0 && !(list.frames[i].first > list.frames[i - 1].first)) {
      return "stamps not strictly increasing after sorting";
    }
    if (list.frames[i].second.empty()) return "accepted an empty image path";
  }
  return "";
}

/// One parser, the valid inputs its mutations start from and the words they draw from.
struct FuzzTarget {
  std::string name;
  std::vector<std::string> seeds;
  std::vector<std::string> dictionary;
  std::function<FuzzVerdict(const std::string&)> run;
};

inline std::string readText(const std::string& path) {
  std::ifstream file(path);
  std::stringstream text;
  text << file.rdbuf();
  return text.str();
}

/// `config_dir`: the repository's config/ (default.yaml and place_recognition.yaml are seeds).
inline std::vector<FuzzTarget> parserFuzzTargets(const std::string& config_dir) {
  std::vector<FuzzTarget> targets;
  targets.push_back(
      {"calibration_yaml",
       {"width: 640\nheight: 480\nfx: 500\nfy: 490\ncx: 320\ncy: 240\n"
        "distortion_model: plumb_bob\ndistortion: [-0.28, 0.07, 0.002, -0.001, 0.01]\n",
        "width: 640\nheight: 480\nfx: 500\nfy: 490\ncx: 320\ncy: 240\n"
        "k1: -0.28\nk2: 0.07\np1: 0.002\np2: -0.001\n",
        "image_width: 640\nimage_height: 480\ncamera_name: cam\n"
        "camera_matrix: {rows: 3, cols: 3, data: [500, 0, 320, 0, 490, 240, 0, 0, 1]}\n"
        "distortion_model: plumb_bob\n"
        "distortion_coefficients: {rows: 1, cols: 5, data: [-0.28, 0.07, 0.002, -0.001, 0]}\n",
        "height: 480\nwidth: 640\ndistortion_model: plumb_bob\nD: [-0.28, 0.07, 0, 0, 0]\n"
        "K: [500, 0, 320, 0, 490, 240, 0, 0, 1]\n",
        "%YAML:1.0\nsensor_type: camera\nresolution: [752, 480]\ncamera_model: pinhole\n"
        "intrinsics: [458.654, 457.296, 367.215, 248.375]\n"
        "distortion_model: radial-tangential\n"
        "distortion_coefficients: [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]\n",
        "cam0:\n  camera_model: pinhole\n  intrinsics: [190.9, 190.9, 254.9, 256.8]\n"
        "  resolution: [512, 512]\n  distortion_model: equidistant\n"
        "  distortion_coeffs: [0.0034, 0.0007, -0.002, 0.0002]\n"},
       {"width",
        "height",
        "fx",
        "fy",
        "cx",
        "cy",
        "distortion_model",
        "distortion",
        "D",
        "K",
        "k1",
        "k2",
        "k3",
        "k4",
        "p1",
        "p2",
        "intrinsics",
        "resolution",
        "camera_model",
        "distortion_coeffs",
        "distortion_coefficients",
        "data",
        "cam0",
        "camera_matrix",
        "equidistant",
        "radtan",
        "plumb_bob",
        "pinhole"},
       [](const std::string& text) {
         return judge([&] { return io::parseCalibrationYaml(text, "fuzz.yaml"); }, checkCalibration,
                      {"calibration fuzz.yaml"});
       }});
  targets.push_back({"slam_params_yaml",
                     {readText(config_dir + "/default.yaml"),
                      "tracker:\n  good_inliers: 70\nsearch:\n  min_ncc: 0.7\n"
                      "place_recognition:\n  geometry:\n    min_inliers: 45\n"},
                     {"tracker", "search", "flow", "window_ba", "good_inliers", "min_ncc", "method",
                      "place_recognition", "min_inliers", "true", "false"},
                     [](const std::string& text) {
                       return judge([&] { return io::parseSlamParams(text, "fuzz.yaml"); },
                                    checkSlamParams,
                                    {"parameters fuzz.yaml", "place recognition params fuzz.yaml"});
                     }});
  targets.push_back(
      {"place_recognition_yaml",
       {readText(config_dir + "/place_recognition.yaml")},
       {"appearance", "vocabulary", "geometry", "ratio", "min_inliers", "max_features", "seed"},
       [](const std::string& text) {
         return judge([&] { return io::parsePlaceRecognitionParams(text, "fuzz.yaml"); },
                      checkPlaceRecognitionParams, {"place recognition params fuzz.yaml"});
       }});
  const std::vector<std::pair<std::string, io::ListFormat>> lists = {
      {"# timestamp filename\n1305031102.175304 rgb/1305031102.175304.png\n"
       "1305031102.211214 rgb/1305031102.211214.png\n1305031102.243211 rgb/1.png\n",
       io::ListFormat::kTum},
      {"#timestamp [ns],filename\n1403636579763555584,1403636579763555584.png\n"
       "1403636579813555456,1403636579813555456.png\n",
       io::ListFormat::kEuroc},
      {"0.000000e+00\n1.036400e-01\n2.072800e-01\n", io::ListFormat::kKittiTimes}};
  for (const auto& [seed, format] : lists) {
    const std::string name = format == io::ListFormat::kTum     ? "tum_rgb_txt"
                             : format == io::ListFormat::kEuroc ? "euroc_data_csv"
                                                                : "kitti_times_txt";
    targets.push_back(
        {name, {seed}, {"png", "rgb/", ","}, [format = format](const std::string& text) {
           return judge([&] { return io::parseFrameList(text, format, "fuzz.txt", "dir"); },
                        checkFrameList, {"sequence 'fuzz.txt'"});
         }});
  }
  return targets;
}

struct FuzzRun {
  std::string target;
  long iterations = 0, accepted = 0, refused = 0, problems = 0;
  std::string first_problem, first_problem_input;
  double seconds = 0.0;
};

/// `iterations` mutated inputs of `target` from `seed`.
inline FuzzRun runFuzz(const FuzzTarget& target, std::uint64_t seed, long iterations) {
  FuzzMutator mutator(seed, target.dictionary);
  FuzzRun run;
  run.target = target.name;
  const auto start = std::chrono::steady_clock::now();
  for (long i = 0; i < iterations; ++i) {
    const std::string& base = target.seeds[mutator.below(target.seeds.size())];
    const std::string input = mutator.mutateText(base);
    const FuzzVerdict verdict = target.run(input);
    ++run.iterations;
    ++(verdict.accepted ? run.accepted : run.refused);
    if (!verdict.problem.empty() && run.problems++ == 0) {
      run.first_problem = verdict.problem;
      run.first_problem_input = input;
    }
  }
  run.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return run;
}

}  // namespace scale_drift_slam::testing
