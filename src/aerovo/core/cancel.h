// Cooperative cancellation of the long loops inside one frame (SURF detection and description,
// descriptor matching, RANSAC), so that a stop request (SIGINT, SIGTERM, ...) takes effect
// within a fraction of a second even on a huge frame, instead of after the frame.
//
// The flag is the run's stop flag (the one RunFlight's `stop` points to), made visible to the
// loops by a CancelScope for the duration of a VisualOdometry::Process call; the loops call
// CancelRequested() every few hundred rows, points or trials (one relaxed atomic load: nothing
// measurable per point) and, when it is set, stop and throw Cancelled once they have left any
// parallel loop (core/parallel.h). Process-wide rather than passed through every signature: a
// stop request is for the process (the signal handlers are process-wide too), and the loops'
// worker threads see it. Without a scope CancelRequested() is always false.
#pragma once

#include <atomic>
#include <stdexcept>
#include <string>

#include "aerovo/core/error.h"

namespace aerovo {


namespace cancel_detail {
inline std::atomic<const std::atomic<bool>*>& Flag() {
  static std::atomic<const std::atomic<bool>*> flag{nullptr};
  return flag;
}
}  // namespace cancel_detail

/// True once the flag of the active CancelScope is set.
inline bool CancelRequested() {
  const std::atomic<bool>* f = cancel_detail::Flag().load(std::memory_order_relaxed);
  return f != nullptr && f->load(std::memory_order_relaxed);
}

/// Throws Cancelled("`where`") when CancelRequested().
inline void ThrowIfCancelled(const char* where) {
  if (CancelRequested()) throw Cancelled(where);
}

/// While alive, CancelRequested() reads `flag` (null: no change). Restores the previous flag.
class CancelScope {
 public:
  explicit CancelScope(const std::atomic<bool>* flag)
      : previous_(flag != nullptr ? cancel_detail::Flag().exchange(flag)
                                  : cancel_detail::Flag().load()),
        set_(flag != nullptr) {}
  ~CancelScope() {
    if (set_) cancel_detail::Flag().store(previous_);
  }
  CancelScope(const CancelScope&) = delete;
  CancelScope& operator=(const CancelScope&) = delete;

 private:
  const std::atomic<bool>* previous_;
  bool set_;
};

}  // namespace aerovo
