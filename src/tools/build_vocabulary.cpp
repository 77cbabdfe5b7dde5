// build_vocabulary: learns a binary vocabulary (loop::Vocabulary) from the images of one or more
// folders and writes it as a small file for place recognition's `vocabulary_file`
// (doc/place_recognition.md). The default needs no file at all: the vocabulary is learned online.

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "scale_drift_slam/common/stopwatch.h"
#include "scale_drift_slam/io/command_line.h"
#include "scale_drift_slam/io/place_recognition_params_io.h"
#include "scale_drift_slam/loop/appearance.h"
#include "scale_drift_slam/loop/vocabulary.h"

namespace sds = scale_drift_slam;
namespace fs = std::filesystem;

namespace {

const char* kUsage =
    "usage: build_vocabulary FOLDER... --out FILE [options]\n"
    "Learns a vocabulary of binary (ORB) words from the images of each FOLDER (a TUM-layout\n"
    "folder with rgb.txt, or a folder of .png/.jpg images) and writes it to FILE.\n"
    "Options:\n"
    "  --config FILE      place recognition params (appearance and vocabulary sections)\n"
    "  --every N          use every N-th image of each folder (default 10)\n"
    "  --branching K      children per node (default: the params', 10)\n"
    "  --depth L          levels (default: the params', 4); at most K^L words\n";

/// The image paths of a folder: the order of rgb.txt when present, else sorted file names.
std::vector<std::string> imagesOf(const std::string& folder) {
  std::vector<std::string> paths;
  std::ifstream list(folder + "/rgb.txt");
  if (list) {
    std::string line;
    while (std::getline(list, line)) {
      if (line.empty() || line[0] == '#') continue;
      std::istringstream fields(line);
      double timestamp = 0.0;
      std::string path;
      if (!(fields >> timestamp >> path)) continue;
      std::string full = folder;
      full += '/';
      full += path;
      paths.push_back(std::move(full));
    }
  } else {
    if (!fs::is_directory(folder)) throw std::runtime_error(folder + " is not a folder");
    for (const auto& entry : fs::directory_iterator(folder)) {
      const std::string extension = entry.path().extension().string();
      if (extension == ".png" || extension == ".jpg" || extension == ".jpeg") {
        paths.push_back(entry.path().string());
      }
    }
    std::sort(paths.begin(), paths.end());
  }
  if (paths.empty()) throw std::runtime_error(folder + " holds no image");
  return paths;
}

int run(const sds::io::CommandLine& cl) {
  cl.rejectUnknownFlags({"out", "config", "every", "branching", "depth"});
  const std::string out = cl.required("out");
  if (cl.positional().empty()) throw std::invalid_argument("give at least one FOLDER");
  sds::loop::PlaceRecognitionParams params;
  if (cl.has("config")) params = sds::io::loadPlaceRecognitionParams(cl.required("config"));
  params.vocabulary.branching =
      static_cast<int>(cl.integer("branching", params.vocabulary.branching));
  params.vocabulary.depth = static_cast<int>(cl.integer("depth", params.vocabulary.depth));
  params.validate();
  const long every = cl.integer("every", 10);
  if (every < 1) throw std::invalid_argument("--every must be >= 1");

  sds::loop::AppearanceExtractor extractor(params.appearance);
  std::vector<cv::Mat> descriptors;
  for (const std::string& folder : cl.positional()) {
    const std::vector<std::string> paths = imagesOf(folder);
    for (std::size_t i = 0; i < paths.size(); i += static_cast<std::size_t>(every)) {
      const cv::Mat image = cv::imread(paths[i], cv::IMREAD_GRAYSCALE);
      if (image.empty()) throw std::runtime_error("cannot read image " + paths[i]);
      descriptors.push_back(extractor.extract(image).descriptors);
    }
  }
  const sds::common::Stopwatch timer;
  const sds::loop::Vocabulary vocabulary =
      sds::loop::Vocabulary::train(descriptors, params.vocabulary);
  const double seconds = timer.seconds();
  vocabulary.save(out);
  std::printf("%zu images -> %zu words (k=%d, L=%d) in %.1f s; %s: %.0f kB\n", descriptors.size(),
              vocabulary.numWords(), vocabulary.branching(), vocabulary.depth(), seconds,
              out.c_str(), static_cast<double>(fs::file_size(out)) / 1024.0);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return sds::io::runTool(argc, argv, kUsage, {}, run);
}
