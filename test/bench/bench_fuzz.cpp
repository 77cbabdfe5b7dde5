// Benchmark: the parser fuzz run of test/io/test_parser_fuzz.cpp with a longer budget (issue 17).
// For each parser: inputs tried, accepted, refused, problems (crash-free but wrong outcomes:
// a foreign exception, an accepted non-finite value), inputs per second. Writes the figures to
// the JSON file given as the first argument; scripts/bench fuzz runs it.
// Usage: bench_fuzz OUT.json [ITERATIONS per parser, default 100000] [SEED, default 1]

#include <cstdio>
#include <fstream>
#include <string>

#include "../io/parser_fuzz_targets.h"

int main(int argc, char** argv) {
  using namespace scale_drift_slam::testing;
  const std::string out = argc > 1 ? argv[1] : "bench_fuzz.json";
  const long iterations = argc > 2 ? std::stol(argv[2]) : 100000;
  const std::uint64_t seed = argc > 3 ? std::stoull(argv[3]) : 1;
  std::ofstream json(out);
  json << "{\n  \"seed\": " << seed << ",\n  \"targets\": [\n";
  std::printf("%-24s %10s %10s %10s %9s %12s\n", "parser", "inputs", "accepted", "refused",
              "problems", "inputs/s");
  int total_problems = 0;
  bool first = true;
  for (const FuzzTarget& target :
       parserFuzzTargets(std::string(SDS_TEST_DATA_DIR) + "/../../config")) {
    // The long parameter file costs ~20x a calibration: a twentieth of the inputs.
    const long n = target.name == "slam_params_yaml" ? iterations / 20 : iterations;
    const FuzzRun run = runFuzz(target, seed, n);
    total_problems += static_cast<int>(run.problems);
    std::printf("%-24s %10ld %10ld %10ld %9ld %12.0f\n", run.target.c_str(), run.iterations,
                run.accepted, run.refused, run.problems, run.iterations / run.seconds);
    if (run.problems > 0) {
      std::printf("  first problem: %s\n  input: %s\n", run.first_problem.c_str(),
                  run.first_problem_input.c_str());
    }
    json << (first ? "" : ",\n") << "    {\"parser\": \"" << run.target
         << "\", \"inputs\": " << run.iterations << ", \"accepted\": " << run.accepted
         << ", \"refused\": " << run.refused << ", \"problems\": " << run.problems
         << ", \"seconds\": " << run.seconds
         << ", \"inputs_per_second\": " << run.iterations / run.seconds << "}";
    first = false;
  }
  json << "\n  ],\n  \"problems\": " << total_problems << "\n}\n";
  std::printf("figures in %s\n", out.c_str());
  return total_problems == 0 ? 0 : 1;
}
