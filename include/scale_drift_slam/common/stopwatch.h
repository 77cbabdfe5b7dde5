#pragma once
// Wall time of a piece of work (the steady clock, so a changed system time does not disturb it).

#include <chrono>

namespace scale_drift_slam::common {

class Stopwatch {
 public:
  double seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }
  double ms() const { return 1e3 * seconds(); }
  void restart() { start_ = std::chrono::steady_clock::now(); }

 private:
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

}  // namespace scale_drift_slam::common
