// Wall-clock timing of pipeline stages (milliseconds), for per-stage figures in results.
#pragma once

#include <time.h>

#include <chrono>

namespace aerovo {

/// Seconds on the steady (monotonic) clock since an unspecified epoch: for intervals between
/// threads of one process (frame capture-to-send latency), never for calendar time.
inline double SteadySeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

class Stopwatch {
 public:
  Stopwatch() : start_(Clock::now()) {}
  void restart() { start_ = Clock::now(); }
  /// Milliseconds since construction or the last restart().
  double elapsed_ms() const {
    return std::chrono::duration<double, std::milli>(Clock::now() - start_).count();
  }

 private:
  using Clock = std::chrono::steady_clock;
  Clock::time_point start_;
};

/// CPU time of the whole process (every thread, user + system; POSIX CLOCK_PROCESS_CPUTIME_ID),
/// in seconds since construction: what a run costs in CPU whatever the number of cores it used.
/// Counts every thread of the process, including any that is not part of the measured work.
class CpuStopwatch {
 public:
  CpuStopwatch() : start_s_(Now()) {}
  double elapsed_s() const { return Now() - start_s_; }

 private:
  static double Now() {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
  }
  double start_s_;
};

}  // namespace aerovo
