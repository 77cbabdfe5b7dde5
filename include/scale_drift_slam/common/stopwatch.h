#pragma once
// Wall time of a piece of work (the steady clock, so a changed system time does not disturb it),
// and the CPU time of the calling thread (unaffected by other processes on a busy machine).

#include <chrono>
#include <ctime>

namespace scale_drift_slam::common {

class Stopwatch {
 public:
  double seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }
  double ms() const { return 1e3 * seconds(); }
  void restart() { start_ = std::chrono::steady_clock::now(); }
  /// Milliseconds since the last lap (or the start), and starts the next lap: for stage times.
  double lapMs() {
    const double elapsed = ms();
    restart();
    return elapsed;
  }

 private:
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

/// CPU time of the calling thread in milliseconds (POSIX CLOCK_THREAD_CPUTIME_ID).
inline double threadCpuMs() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

}  // namespace scale_drift_slam::common
