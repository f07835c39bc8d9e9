#include "aerovo/core/parallel.h"

#include <sched.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <memory>
#include <mutex>
#include <system_error>
#include <thread>
#include <vector>

namespace aerovo {

int AvailableCores() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (::sched_getaffinity(0, sizeof(set), &set) == 0) return std::max(1, CPU_COUNT(&set));
  return std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

int ResolveThreadCount(int requested) { return requested == 0 ? AvailableCores() : requested; }

namespace parallel_detail {
namespace {

// True on a pool worker and on a caller while it runs chunks: a ParallelFor there runs serially.
thread_local bool tl_inside_body = false;

// One ParallelFor call: the range, the next chunk to hand out, the first exception.
struct Job {
  long n = 0, chunk = 1;
  ChunkFn fn = nullptr;
  void* body = nullptr;
  std::atomic<long> next{0};
  std::atomic<bool> failed{false};
  std::mutex error_mutex;
  std::exception_ptr error;

  // Takes chunks until none is left (or a body threw) and runs them as `worker`.
  void Work(int worker) {
    while (!failed.load(std::memory_order_relaxed)) {
      const long begin = next.fetch_add(chunk, std::memory_order_relaxed);
      if (begin >= n) return;
      try {
        fn(body, begin, std::min(n, begin + chunk), worker);
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!error) error = std::current_exception();
        failed.store(true, std::memory_order_relaxed);
      }
    }
  }
};

// The workers of one calling thread. Run hands a job to the first `helpers` workers, works on it
// too, and returns when they are done; between jobs the workers sleep on `wake_`.
class WorkerPool {
 public:
  WorkerPool() = default;
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;
  ~WorkerPool() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    for (std::thread& t : threads_) t.join();
  }

  void Run(int helpers, Job& job) {
    while (static_cast<int>(threads_.size()) < helpers) {
      try {
        threads_.emplace_back(&WorkerPool::Loop, this, static_cast<int>(threads_.size()));
      } catch (const std::system_error&) {  // the thread limit: the others share the work
        break;
      }
    }
    helpers = std::min(helpers, static_cast<int>(threads_.size()));
    {
      std::lock_guard<std::mutex> lock(mutex_);
      job_ = &job;
      helpers_ = helpers;
      pending_ = helpers;
      ++generation_;
    }
    if (helpers > 0) wake_.notify_all();
    job.Work(0);
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [this] { return pending_ == 0; });
    job_ = nullptr;
  }

 private:
  // Worker `index` (1 + index in the job): waits for a job that includes it, works, reports.
  void Loop(int index) {
    tl_inside_body = true;
    std::uint64_t seen = 0;
    for (;;) {
      Job* job = nullptr;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [&] { return stop_ || (generation_ != seen && index < helpers_); });
        if (stop_) return;
        seen = generation_;
        job = job_;
      }
      job->Work(index + 1);
      std::lock_guard<std::mutex> lock(mutex_);
      if (--pending_ == 0) done_.notify_one();
    }
  }

  std::mutex mutex_;
  std::condition_variable wake_, done_;
  std::vector<std::thread> threads_;
  Job* job_ = nullptr;
  std::uint64_t generation_ = 0;
  int helpers_ = 0;  // workers 0 .. helpers_ - 1 take part in the current job
  int pending_ = 0;  // of those, the ones not done yet
  bool stop_ = false;
};

}  // namespace

void Run(int threads, long n, long chunk, ChunkFn fn, void* body) {
  if (n <= 0) return;
  chunk = std::max(1L, chunk);
  if (threads <= 1 || n <= chunk || tl_inside_body) {
    for (long begin = 0; begin < n; begin += chunk) fn(body, begin, std::min(n, begin + chunk), 0);
    return;
  }
  // The calling thread's pool. A child of fork() inherits the parent's pool but none of its
  // threads (fork(2) copies the calling thread only), and its mutex may have been held by a
  // worker at the fork: the child leaves that pool as it is, never destroyed (its threads
  // cannot be joined), and starts its own. (libgomp's pool hung in such a child.)
  thread_local std::unique_ptr<WorkerPool> pool;
  thread_local pid_t pool_pid = 0;
  if (const pid_t pid = ::getpid(); pool == nullptr || pool_pid != pid) {
    if (pool != nullptr) static_cast<void>(pool.release());
    pool = std::make_unique<WorkerPool>();
    pool_pid = pid;
  }
  Job job;
  job.n = n;
  job.chunk = chunk;
  job.fn = fn;
  job.body = body;
  // Not more helpers than chunks after the caller's first.
  const long chunks = (n + chunk - 1) / chunk;
  const int helpers = static_cast<int>(std::min<long>(threads - 1, chunks - 1));
  struct InsideBody {  // the caller's chunks count as inside a body, until Run returns
    InsideBody() { tl_inside_body = true; }
    ~InsideBody() { tl_inside_body = false; }
  };
  {
    const InsideBody inside;
    pool->Run(helpers, job);
  }
  if (job.error) std::rethrow_exception(job.error);
}

}  // namespace parallel_detail
}  // namespace aerovo
