#include "scale_drift_slam/io/command_line.h"

#include <cstdlib>
#include <iostream>
#include <stdexcept>

namespace scale_drift_slam::io {

CommandLine::CommandLine(int argc, const char* const* argv,
                         const std::set<std::string>& boolean_flags) {
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      help_ = true;
    } else if (arg.rfind("--", 0) == 0 && arg.size() > 2) {
      const size_t equals = arg.find('=');
      if (equals != std::string::npos) {
        flags_.emplace_back(arg.substr(2, equals - 2), arg.substr(equals + 1));
      } else {
        const std::string name = arg.substr(2);
        if (boolean_flags.count(name)) {
          flags_.emplace_back(name, "true");
        } else if (i + 1 < argc) {
          flags_.emplace_back(name, argv[++i]);
        } else {
          throw std::invalid_argument("flag --" + name + " needs a value");
        }
      }
    } else {
      positional_.push_back(arg);
    }
  }
}

const std::string& CommandLine::positional(std::size_t i, const std::string& what) const {
  if (i >= positional_.size()) throw std::invalid_argument("missing argument: " + what);
  return positional_[i];
}

bool CommandLine::has(const std::string& flag) const {
  return value(flag).has_value();
}

std::optional<std::string> CommandLine::value(const std::string& flag) const {
  std::optional<std::string> result;
  for (const auto& [name, value] : flags_) {
    if (name == flag) result = value;  // the last occurrence wins
  }
  return result;
}

std::string CommandLine::required(const std::string& flag) const {
  const auto v = value(flag);
  if (!v) throw std::invalid_argument("missing required flag --" + flag);
  return *v;
}

std::string CommandLine::text(const std::string& flag, const std::string& fallback) const {
  return value(flag).value_or(fallback);
}

double CommandLine::number(const std::string& flag, double fallback) const {
  const auto v = value(flag);
  if (!v) return fallback;
  char* end = nullptr;
  const double parsed = std::strtod(v->c_str(), &end);
  if (v->empty() || *end != '\0') {
    throw std::invalid_argument("--" + flag + " expects a number, got '" + *v + "'");
  }
  return parsed;
}

long CommandLine::integer(const std::string& flag, long fallback) const {
  const auto v = value(flag);
  if (!v) return fallback;
  char* end = nullptr;
  const long parsed = std::strtol(v->c_str(), &end, 10);
  if (v->empty() || *end != '\0') {
    throw std::invalid_argument("--" + flag + " expects an integer, got '" + *v + "'");
  }
  return parsed;
}

void CommandLine::rejectUnknownFlags(const std::set<std::string>& known) const {
  for (const auto& flag : flags_) {
    if (!known.count(flag.first)) {
      throw std::invalid_argument("unknown flag --" + flag.first);
    }
  }
}

int runTool(int argc, const char* const* argv, const std::string& usage,
            const std::set<std::string>& boolean_flags,
            const std::function<int(const CommandLine&)>& body) {
  std::string tool = argc > 0 ? argv[0] : "tool";
  tool = tool.substr(tool.find_last_of('/') + 1);
  try {
    const CommandLine command_line(argc, argv, boolean_flags);
    if (command_line.helpRequested()) {
      std::cout << usage;
      return 0;
    }
    return body(command_line);
  } catch (const std::invalid_argument& e) {
    std::cerr << tool << ": error: " << e.what() << " (see --help)\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << tool << ": error: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace scale_drift_slam::io
