// Fuzz test of every file parser (issue 17): thousands of seeded random mutations of valid
// calibration YAML (all layouts), parameter YAML (config/default.yaml, place_recognition.yaml)
// and dataset lists (rgb.txt, data.csv, times.txt): no crash, no hang, no exception other than
// the parser's own error, and nothing accepted that is non-finite or fails validation. A short
// budget here (a few seconds); `scripts/bench fuzz` runs a longer one (test/bench/bench_fuzz.cpp).

#include <cmath>
#include <iostream>

#include <gtest/gtest.h>

#include "parser_fuzz_targets.h"

namespace scale_drift_slam::testing {
namespace {

const std::string kConfigDir = std::string(SDS_TEST_DATA_DIR) + "/../../config";

TEST(FuzzMutator, SameSeedSameInputsAndEveryInputChanges) {
  FuzzMutator a(7, {"fx"}), b(7, {"fx"});
  const std::string seed = "width: 640\nfx: 500\n";
  int changed = 0;
  for (int i = 0; i < 200; ++i) {
    const std::string x = a.mutateText(seed);
    EXPECT_EQ(x, b.mutateText(seed));
    changed += x != seed ? 1 : 0;
  }
  EXPECT_GT(changed, 150);  // a swap of a word with itself may leave the text as it was
  int non_finite = 0;
  for (int i = 0; i < 100; ++i)
    non_finite += std::isfinite(a.nastyDouble()) ? 0 : 1;
  EXPECT_GT(non_finite, 10);
}

TEST(ParserFuzz, NoCrashNoForeignExceptionNoAcceptedNonFinite) {
  for (const FuzzTarget& target : parserFuzzTargets(kConfigDir)) {
    for (const std::string& seed : target.seeds) {
      const FuzzVerdict verdict = target.run(seed);
      EXPECT_TRUE(verdict.accepted) << target.name << " refuses its own seed:\n" << seed;
      EXPECT_EQ(verdict.problem, "") << target.name;
    }
    // The parameter files are long (default.yaml: ~200 lines): fewer of them.
    const long iterations = target.name == "slam_params_yaml" ? 2000 : 8000;
    const FuzzRun run = runFuzz(target, /*seed=*/17, iterations);
    EXPECT_EQ(run.problems, 0) << target.name << ": " << run.first_problem << "\ninput:\n"
                               << run.first_problem_input;
    // Both outcomes occur: the mutations reach past the first check, and break things.
    EXPECT_GT(run.accepted, 0) << target.name;
    EXPECT_GT(run.refused, iterations / 10) << target.name;
    std::cout << target.name << ": " << run.iterations << " inputs, " << run.accepted
              << " accepted, " << run.refused << " refused\n";
  }
}

}  // namespace
}  // namespace scale_drift_slam::testing
