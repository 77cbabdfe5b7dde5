#include "scale_drift_slam/io/run_statistics.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <numeric>
#include <sstream>

#include <unistd.h>

namespace scale_drift_slam::io {

double percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const double rank = std::ceil(std::clamp(q, 0.0, 1.0) * values.size());
  const std::size_t index = rank < 1.0 ? 0 : static_cast<std::size_t>(rank) - 1;
  return values[std::min(index, values.size() - 1)];
}

void StageTimings::add(const std::string& stage, double ms) {
  if (!values_.count(stage)) order_.push_back(stage);
  values_[stage].push_back(ms);
}

const std::vector<double>& StageTimings::values(const std::string& stage) const {
  static const std::vector<double> kNone;
  const auto it = values_.find(stage);
  return it == values_.end() ? kNone : it->second;
}

nlohmann::json StageTimings::toJson() const {
  nlohmann::json json = nlohmann::json::object();
  for (const std::string& stage : order_) {
    const std::vector<double>& v = values_.at(stage);
    json[stage] = {{"median_ms", percentile(v, 0.5)},
                   {"p95_ms", percentile(v, 0.95)},
                   {"mean_ms", std::accumulate(v.begin(), v.end(), 0.0) / v.size()},
                   {"max_ms", *std::max_element(v.begin(), v.end())},
                   {"count", v.size()}};
  }
  return json;
}

std::string StageTimings::table() const {
  std::ostringstream out;
  char line[160];
  std::snprintf(line, sizeof(line), "%-16s %10s %10s %10s %8s\n", "stage", "median ms", "p95 ms",
                "mean ms", "count");
  out << line;
  for (const std::string& stage : order_) {
    const std::vector<double>& v = values_.at(stage);
    std::snprintf(line, sizeof(line), "%-16s %10.2f %10.2f %10.2f %8zu\n", stage.c_str(),
                  percentile(v, 0.5), percentile(v, 0.95),
                  std::accumulate(v.begin(), v.end(), 0.0) / v.size(), v.size());
    out << line;
  }
  return out.str();
}

double peakMemoryMiB() {
  std::ifstream status("/proc/self/status");
  std::string key;
  while (status >> key) {
    if (key == "VmHWM:") {
      double kib = 0.0;
      status >> kib;
      return kib / 1024.0;
    }
  }
  return 0.0;
}

double residentMemoryMiB() {
  std::ifstream statm("/proc/self/statm");
  double pages_total = 0.0, pages_resident = 0.0;
  if (!(statm >> pages_total >> pages_resident)) return 0.0;
  return pages_resident * static_cast<double>(sysconf(_SC_PAGESIZE)) / (1024.0 * 1024.0);
}

}  // namespace scale_drift_slam::io
