#pragma once
// Figures of an offline run: per-stage timing (median, 95th percentile, mean), counts, and the
// process's peak memory, printed as a table and written as JSON (run_sequence's summary.json).

#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace scale_drift_slam::io {

/// The q-quantile (q in [0, 1]) by the nearest rank of the sorted values; 0 for none.
double percentile(std::vector<double> values, double q);

/// Durations per named stage, in the order the stages were first seen.
class StageTimings {
 public:
  void add(const std::string& stage, double ms);
  /// {"stage": {"median_ms", "p95_ms", "mean_ms", "max_ms", "count"}, ...}
  nlohmann::json toJson() const;
  /// One line per stage: name, median, p95, mean, count.
  std::string table() const;
  const std::vector<double>& values(const std::string& stage) const;

 private:
  std::vector<std::string> order_;
  std::map<std::string, std::vector<double>> values_;
};

/// The peak resident memory of this process (VmHWM of /proc/self/status) in MiB; 0 if unknown.
double peakMemoryMiB();
/// The resident memory of this process now (VmRSS, from /proc/self/statm) in MiB; 0 if unknown.
double residentMemoryMiB();

}  // namespace scale_drift_slam::io
