// ParallelFor (core/parallel.h): every index once, chunks in order, worker indices, exceptions,
// nesting, several callers at once, the thread limit, and idle workers that take no CPU.
#include "aerovo/core/parallel.h"

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <signal.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <mutex>
#include <numeric>
#include <stdexcept>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace aerovo {
namespace {

TEST(ParallelFor, EveryIndexOnceInChunksOfTheGivenSizeOnValidWorkers) {
  for (const int threads : {1, 2, 3, 8}) {
    for (const long n : {0L, 1L, 7L, 64L, 1000L, 1001L}) {
      for (const long chunk : {1L, 16L, 64L}) {
        std::vector<int> hits(n, 0);
        std::mutex m;
        std::vector<std::pair<long, long>> chunks;
        std::atomic<bool> bad_worker{false};
        ParallelFor(threads, n, chunk, [&](long begin, long end, int worker) {
          if (worker < 0 || worker >= threads) bad_worker = true;
          for (long i = begin; i < end; ++i) ++hits[i];
          std::lock_guard<std::mutex> lock(m);
          chunks.emplace_back(begin, end);
        });
        SCOPED_TRACE(testing::Message() << threads << " threads, n " << n << ", chunk " << chunk);
        EXPECT_FALSE(bad_worker);
        EXPECT_TRUE(std::all_of(hits.begin(), hits.end(), [](int h) { return h == 1; }));
        std::sort(chunks.begin(), chunks.end());
        ASSERT_EQ(static_cast<long>(chunks.size()), (n + chunk - 1) / chunk);
        for (std::size_t c = 0; c < chunks.size(); ++c) {
          EXPECT_EQ(chunks[c].first, static_cast<long>(c) * chunk);
          EXPECT_EQ(chunks[c].second, std::min(n, chunks[c].first + chunk));
        }
      }
    }
  }
}

// Blocks the calling chunk until a chunk has started on another worker, or `timeout` passes:
// whichever thread took chunk 0 holds it, so the rest can only run elsewhere. Without it, how many
// chunks a helper gets depends on how fast the scheduler wakes it.
bool WaitForAnotherWorker(const std::atomic<int>& workers_seen, std::chrono::seconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (workers_seen.load() < 2) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::microseconds(100));
  }
  return true;
}

// The helpers do take chunks (not the caller alone), and the per-worker scratch pattern gives
// the same sum as one thread.
TEST(ParallelFor, WorkersShareTheWorkAndPerWorkerScratchSumsAlike) {
  constexpr int kThreads = 4;
  constexpr long kN = 4000;
  std::vector<long> per_worker(kThreads, 0);
  std::vector<std::thread::id> ids(kN);
  std::atomic<unsigned> worker_bits{0};
  std::atomic<int> workers_seen{0};
  std::atomic<bool> waited{true};
  ParallelFor(kThreads, kN, 1, [&](long begin, long end, int worker) {
    if ((worker_bits.fetch_or(1u << worker) & (1u << worker)) == 0) ++workers_seen;
    if (begin == 0) waited = WaitForAnotherWorker(workers_seen, std::chrono::seconds(10));
    for (long i = begin; i < end; ++i) {
      per_worker[worker] += i;
      ids[i] = std::this_thread::get_id();
    }
  });
  ASSERT_TRUE(waited) << "no second worker took a chunk in 10 s";
  EXPECT_EQ(std::accumulate(per_worker.begin(), per_worker.end(), 0L), kN * (kN - 1) / 2);
  std::sort(ids.begin(), ids.end());
  EXPECT_GE(std::unique(ids.begin(), ids.end()) - ids.begin(), 2);
}

TEST(ParallelFor, SerialRunsTheChunksInOrderOnTheCaller) {
  std::vector<long> order;
  const std::thread::id caller = std::this_thread::get_id();
  bool elsewhere = false;
  ParallelFor(1, 10, 3, [&](long begin, long end, int worker) {
    elsewhere |= std::this_thread::get_id() != caller || worker != 0;
    order.push_back(begin);
    EXPECT_EQ(end, std::min(10L, begin + 3));
  });
  EXPECT_FALSE(elsewhere);
  EXPECT_EQ(order, (std::vector<long>{0, 3, 6, 9}));
}

// Each other chunk takes at least 200 us, so the one worker that goes on alone would need at
// least 4 s for all 20000; the exception is recorded in well under that even under the sanitizers
// (unwinding there takes milliseconds, in which trivial chunks would all have run).
TEST(ParallelFor, TheFirstExceptionIsRethrownAndTheRestIsNotStarted) {
  constexpr long kN = 20000;
  std::atomic<long> started{0};
  EXPECT_THROW(ParallelFor(2, kN, 1,
                           [&](long begin, long, int) {
                             ++started;
                             if (begin == 10) throw std::runtime_error("chunk 10");
                             std::this_thread::sleep_for(std::chrono::microseconds(200));
                           }),
               std::runtime_error);
  EXPECT_LT(started.load(), kN / 2);
  // The pool is usable afterwards.
  std::atomic<long> sum{0};
  ParallelFor(2, 100, 1, [&](long begin, long, int) { sum += begin; });
  EXPECT_EQ(sum.load(), 4950);
  // The exception itself, not a copy of another type.
  try {
    ParallelFor(2, 10, 1, [](long begin, long, int) {
      if (begin == 3) throw std::invalid_argument("three");
    });
    ADD_FAILURE() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "three");
  }
}

// A ParallelFor inside a body runs on that body's thread, in order, as worker 0.
TEST(ParallelFor, NestedCallsRunSerially) {
  std::vector<std::vector<long>> inner(8);
  ParallelFor(2, 8, 1, [&](long begin, long, int) {
    const std::thread::id self = std::this_thread::get_id();
    ParallelFor(4, 5, 1, [&](long b, long, int worker) {
      EXPECT_EQ(std::this_thread::get_id(), self);
      EXPECT_EQ(worker, 0);
      inner[begin].push_back(b);
    });
  });
  for (const auto& v : inner) EXPECT_EQ(v, (std::vector<long>{0, 1, 2, 3, 4}));
}

// Threads that call at the same time each use their own workers (the map-fix thread runs SURF
// while the frame loop does).
TEST(ParallelFor, SeveralCallersAtOnce) {
  constexpr int kCallers = 4;
  std::vector<long> sums(kCallers, 0);
  std::vector<std::thread> callers;
  for (int c = 0; c < kCallers; ++c) {
    callers.emplace_back([&sums, c] {
      for (int round = 0; round < 50; ++round) {
        std::vector<long> part(3, 0);
        ParallelFor(3, 1000, 7, [&](long begin, long end, int worker) {
          for (long i = begin; i < end; ++i) part[worker] += i;
        });
        sums[c] += std::accumulate(part.begin(), part.end(), 0L);
      }
    });
  }
  for (std::thread& t : callers) t.join();
  for (const long s : sums) EXPECT_EQ(s, 50L * 999 * 1000 / 2);
}

// Between calls the workers sleep: a second after a 4-thread loop the process has used (almost)
// no CPU. OpenMP's default spinning used 10-100 ms of CPU per region's worker here.
TEST(ParallelFor, IdleWorkersTakeNoCpu) {
  std::atomic<long> sum{0};
  ParallelFor(4, 64, 1, [&](long begin, long, int) { sum += begin; });
  const auto cpu_s = [] {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return u.ru_utime.tv_sec + u.ru_stime.tv_sec + 1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
  };
  const double before = cpu_s();
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  EXPECT_LT(cpu_s() - before, 0.05) << "workers busy while idle";
  EXPECT_EQ(sum.load(), 64 * 63 / 2);
}

// A child of fork() (Python's multiprocessing) has the parent's pool but not its threads: its
// loops run on workers of its own instead of waiting for the parent's forever.
TEST(ParallelFor, AForkedChildRunsItsLoopsOnItsOwnWorkers) {
  std::atomic<long> sum{0};
  ParallelFor(2, 64, 1, [&](long begin, long, int) { sum += begin; });
  ASSERT_EQ(sum.load(), 64 * 63 / 2);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    std::atomic<long> s{0};
    std::atomic<unsigned> worker_bits{0};
    std::atomic<int> workers_seen{0};
    std::atomic<bool> waited{true};
    ParallelFor(2, 4000, 1, [&](long begin, long, int worker) {
      s += begin;
      if ((worker_bits.fetch_or(1u << worker) & (1u << worker)) == 0) ++workers_seen;
      if (begin == 0) waited = WaitForAnotherWorker(workers_seen, std::chrono::seconds(5));
    });
    ::_exit(s.load() == 4000L * 3999 / 2 && waited.load() && worker_bits.load() == 3u ? 0 : 1);
  }
  int status = 0;
  pid_t done = 0;
  for (int i = 0; i < 1000 && done == 0; ++i) {  // up to 10 s
    done = ::waitpid(child, &status, WNOHANG);
    if (done == 0) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  if (done == 0) {
    ::kill(child, SIGKILL);
    ::waitpid(child, &status, 0);
    FAIL() << "the child's loop did not finish in 10 s";
  }
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "wrong sum or no second worker in the child";
}

TEST(ParallelFor, ThreadCountZeroIsTheCoresThisProcessMayUse) {
  EXPECT_GE(AvailableCores(), 1);
  EXPECT_LE(AvailableCores(), static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
  EXPECT_EQ(ResolveThreadCount(0), AvailableCores());
  EXPECT_EQ(ResolveThreadCount(3), 3);
}

}  // namespace
}  // namespace aerovo
