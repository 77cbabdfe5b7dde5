// Run statistics: nearest-rank percentiles on known data, per-stage JSON and table, and the
// process's peak memory is read (it is at least the size of a buffer just touched).

#include <gtest/gtest.h>

#include "scale_drift_slam/io/run_statistics.h"

namespace scale_drift_slam::io {
namespace {

TEST(RunStatistics, PercentilesByNearestRank) {
  std::vector<double> v;
  for (int i = 100; i >= 1; --i)
    v.push_back(i);
  EXPECT_EQ(percentile(v, 0.5), 50.0);
  EXPECT_EQ(percentile(v, 0.95), 95.0);
  EXPECT_EQ(percentile(v, 1.0), 100.0);
  EXPECT_EQ(percentile(v, 0.0), 1.0);
  EXPECT_EQ(percentile({}, 0.5), 0.0);
}

TEST(RunStatistics, StagesKeepTheirOrderAndFigures) {
  StageTimings timings;
  for (int i = 1; i <= 20; ++i) {
    timings.add("flow", i);
    timings.add("search", 2.0 * i);
  }
  const nlohmann::json json = timings.toJson();
  EXPECT_EQ(json["flow"]["median_ms"], 10.0);
  EXPECT_EQ(json["flow"]["p95_ms"], 19.0);
  EXPECT_EQ(json["search"]["max_ms"], 40.0);
  EXPECT_EQ(json["search"]["count"], 20);
  EXPECT_DOUBLE_EQ(json["search"]["mean_ms"].get<double>(), 21.0);
  const std::string table = timings.table();
  EXPECT_LT(table.find("flow"), table.find("search"));
  EXPECT_TRUE(timings.values("nothing").empty());
}

TEST(RunStatistics, ReadsPeakMemory) {
  std::vector<char> buffer(64 << 20, 1);  // touch 64 MiB
  EXPECT_GT(peakMemoryMiB(), 64.0 * buffer[12345]);
}

}  // namespace
}  // namespace scale_drift_slam::io
