#pragma once
// The shared command-line handling of the tools in src/tools: flags as "--name value" or
// "--name=value", positional arguments, --help, and one-line errors with a non-zero exit code.

#include <functional>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace scale_drift_slam::io {

class CommandLine {
 public:
  /// `boolean_flags` take no value ("--se3"); every other "--flag" takes one.
  CommandLine(int argc, const char* const* argv, const std::set<std::string>& boolean_flags = {});

  bool helpRequested() const { return help_; }
  const std::vector<std::string>& positional() const { return positional_; }
  /// The i-th positional argument; throws std::invalid_argument naming `what` when absent.
  const std::string& positional(std::size_t i, const std::string& what) const;

  bool has(const std::string& flag) const;
  std::optional<std::string> value(const std::string& flag) const;
  /// The value of a flag that must be given; throws std::invalid_argument otherwise.
  std::string required(const std::string& flag) const;
  std::string text(const std::string& flag, const std::string& fallback) const;
  /// Parsed numbers; a malformed value throws std::invalid_argument naming the flag.
  double number(const std::string& flag, double fallback) const;
  long integer(const std::string& flag, long fallback) const;

  /// Throws std::invalid_argument for a flag outside `known` (a typo must not pass silently).
  void rejectUnknownFlags(const std::set<std::string>& known) const;

 private:
  bool help_ = false;
  std::vector<std::string> positional_;
  std::vector<std::pair<std::string, std::string>> flags_;
};

/// Runs a tool's body: prints `usage` for --help (exit 0); turns any exception into one line
/// "<tool>: error: <reason>" on stderr and exit code 1 (2 for bad arguments).
int runTool(int argc, const char* const* argv, const std::string& usage,
            const std::set<std::string>& boolean_flags,
            const std::function<int(const CommandLine&)>& body);

}  // namespace scale_drift_slam::io
