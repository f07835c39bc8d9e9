#include "aerovo/frames/prefetch_source.h"

#include <chrono>
#include <utility>

#include "aerovo/core/error.h"
#include "aerovo/core/timer.h"

namespace aerovo {

struct PrefetchSource::State {
  State(std::unique_ptr<FrameSource> inner_source, const PrefetchOptions& opts)
      : inner(std::move(inner_source)), options(opts) {}

  std::unique_ptr<FrameSource> inner;
  const PrefetchOptions options;

  std::mutex mutex;
  std::condition_variable changed;  // queue, end, error, stop or reader_done changed
  std::deque<Frame> queue;          // decoded, oldest first
  std::vector<Frame> pool;          // frames whose buffers are reused by the reader
  std::vector<std::string> new_warnings;  // inner's warnings not yet moved to warnings_
  bool end = false;                       // inner ended (or threw: error)
  bool stop = false;                      // destructor: reader must quit
  bool reader_done = false;               // ReadLoop returned (joining cannot block)
  std::exception_ptr error;
  std::atomic<int> dropped{0};
};

PrefetchSource::PrefetchSource(std::unique_ptr<FrameSource> inner, const PrefetchOptions& options) {
  if (!inner) throw InvalidArgument("PrefetchSource: the inner frame source is null");
  if (options.capacity < 1) {
    throw InvalidArgument("PrefetchSource: capacity must be >= 1, got " +
                          std::to_string(options.capacity));
  }
  description_ = inner->Describe();
  expected_ = inner->ExpectedFrameCount();
  live_ = inner->IsLive();
  state_ = std::make_shared<State>(std::move(inner), options);
}

PrefetchSource::~PrefetchSource() {
  State& s = *state_;
  std::unique_lock<std::mutex> lock(s.mutex);
  s.stop = true;
  s.changed.notify_all();
  if (!reader_.joinable()) return;
  const auto done = [&] { return s.reader_done; };
  if (s.options.join_timeout_ms < 0) {
    s.changed.wait(lock, done);
  } else if (!s.changed.wait_for(lock, std::chrono::milliseconds(s.options.join_timeout_ms),
                                 done)) {
    // Inside a long inner.Next(): the reader finishes it on its own and ends (it sees stop);
    // its copy of state_ keeps everything it touches alive until then.
    lock.unlock();
    reader_.detach();
    return;
  }
  lock.unlock();
  reader_.join();
}

int PrefetchSource::dropped() const { return state_->dropped.load(); }
const FrameSource& PrefetchSource::inner() const { return *state_->inner; }
const PrefetchOptions& PrefetchSource::options() const { return state_->options; }

void PrefetchSource::ReadLoop(const std::shared_ptr<State>& state) {
  State& s = *state;
  Frame spare;
  std::size_t warnings_seen = 0;
  const auto finish = [&] {
    const std::lock_guard<std::mutex> lock(s.mutex);
    s.reader_done = true;
    s.changed.notify_all();
  };
  while (true) {
    {
      std::unique_lock<std::mutex> lock(s.mutex);
      if (s.options.policy == QueuePolicy::kWait) {
        s.changed.wait(lock, [&] {
          return s.stop || static_cast<int>(s.queue.size()) < s.options.capacity;
        });
      }
      if (s.stop) {
        lock.unlock();
        return finish();
      }
    }
    bool more = false;
    std::exception_ptr error;
    try {
      more = s.inner->Next(spare);
    } catch (...) {
      error = std::current_exception();
    }
    const double received_s = SteadySeconds();
    {
      const std::lock_guard<std::mutex> lock(s.mutex);
      const std::vector<std::string>& w = s.inner->warnings();
      for (; warnings_seen < w.size(); ++warnings_seen) s.new_warnings.push_back(w[warnings_seen]);
      if (error || !more) {
        s.error = error;
        s.end = true;
      } else {
        spare.received_s = received_s;
        if (static_cast<int>(s.queue.size()) >= s.options.capacity) {  // kDropOldest only
          s.pool.push_back(std::move(s.queue.front()));
          s.queue.pop_front();
          s.dropped.fetch_add(1);
        }
        s.queue.push_back(std::move(spare));
        if (!s.pool.empty()) {
          spare = std::move(s.pool.back());
          s.pool.pop_back();
        } else {
          spare = Frame();
        }
      }
    }
    s.changed.notify_all();
    if (error || !more) return finish();
  }
}

bool PrefetchSource::Next(Frame& frame) {
  State& s = *state_;
  if (!reader_.joinable()) reader_ = std::thread([state = state_] { ReadLoop(state); });
  std::unique_lock<std::mutex> lock(s.mutex);
  s.changed.wait(lock, [&] { return !s.queue.empty() || s.end; });
  for (std::string& w : s.new_warnings) warnings_.push_back(std::move(w));
  s.new_warnings.clear();
  if (!s.queue.empty()) {
    std::swap(frame, s.queue.front());
    s.pool.push_back(std::move(s.queue.front()));  // the caller's previous frame, for reuse
    s.queue.pop_front();
    lock.unlock();
    s.changed.notify_all();
    return true;
  }
  if (s.error) {
    std::exception_ptr e = s.error;
    s.error = nullptr;  // thrown once; later calls return false
    std::rethrow_exception(e);
  }
  return false;
}

}  // namespace aerovo
