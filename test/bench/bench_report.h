#pragma once
// A few lines shared by the benchmark programs: time a piece of work several times, keep the
// median and the minimum, print a line per figure and write all figures as JSON to the file named
// by the first argument (scripts/bench collects them). Header-only, benchmark programs only.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace scale_drift_slam::bench {

class Report {
 public:
  Report(std::string name, int argc, char** argv)
      : name_(std::move(name)), path_(argc > 1 ? argv[1] : "") {}
  ~Report() {
    if (path_.empty()) return;
    std::ofstream(path_) << nlohmann::json{{"benchmark", name_}, {"figures", figures_}}.dump(2)
                         << "\n";
  }

  /// Runs `work` `repetitions` times; records and prints the median and minimum in milliseconds.
  double timeMs(const std::string& figure, int repetitions, const std::function<void()>& work,
                const std::string& note = "") {
    std::vector<double> ms;
    for (int i = 0; i < repetitions; ++i) {
      const auto start = std::chrono::steady_clock::now();
      work();
      ms.push_back(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
              .count());
    }
    std::sort(ms.begin(), ms.end());
    const double median = ms[ms.size() / 2];
    add(figure, median, "ms",
        note + (note.empty() ? "" : "; ") + "median of " + std::to_string(repetitions) + ", min " +
            format(ms.front()));
    return median;
  }

  /// Records a figure measured by the caller.
  void add(const std::string& figure, double value, const std::string& unit,
           const std::string& note = "") {
    std::printf("%-60s %12s %-4s %s\n", figure.c_str(), format(value).c_str(), unit.c_str(),
                note.c_str());
    std::fflush(stdout);
    figures_.push_back({{"figure", figure}, {"value", value}, {"unit", unit}, {"note", note}});
  }

 private:
  static std::string format(double value) {
    char buffer[32];
    std::snprintf(buffer, sizeof(buffer), "%.4g", value);
    return buffer;
  }

  std::string name_;
  std::string path_;
  nlohmann::json figures_ = nlohmann::json::array();
};

}  // namespace scale_drift_slam::bench
