// Wall-clock timing of pipeline stages (milliseconds), for per-stage figures in results.
#pragma once

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

}  // namespace aerovo
