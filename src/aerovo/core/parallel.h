// Parallel loops on the calling thread's own workers: what SURF and descriptor matching run
// their per-point loops on (features/surf.cc, matching/matcher.cc).
//
// The workers wait on a condition variable between loops: an idle worker takes no CPU. (OpenMP's
// runtimes spin instead by default, libgomp ~300,000 iterations after each parallel region,
// which on cores shared with an autopilot link, an encoder or a logger halves a 1080p run's
// speed: BENCHMARKS.md, "Busy machine"; and they read their wait policy from the environment
// when they load, before main, which no library can set.)
#pragma once

#include <type_traits>

namespace aerovo {

/// The CPUs this process may run on (sched_getaffinity(2): a container's or `taskset`'s limit,
/// not the machine's count), at least 1: the meaning of a thread count of 0, "one per core".
int AvailableCores();

/// `requested` threads, or AvailableCores() for 0 (requested >= 0).
int ResolveThreadCount(int requested);

namespace parallel_detail {
using ChunkFn = void (*)(void* body, long begin, long end, int worker);
void Run(int threads, long n, long chunk, ChunkFn fn, void* body);
}  // namespace parallel_detail

/// Calls body(begin, end, worker) for consecutive chunks [begin, end) of [0, n), `chunk` indices
/// each (the last one shorter), on `threads` threads: the caller (worker 0) and threads - 1
/// workers of its own (worker 1 ... threads - 1). Chunks are handed out in increasing order to
/// whichever thread is free (OpenMP's schedule(dynamic, chunk)), so which worker runs a chunk
/// varies from call to call: body must write only its indices' own results, or per-worker
/// scratch indexed by `worker`. Returns when every chunk is done.
///
/// threads <= 1, n <= chunk, or a call from inside a body: the whole range on the calling
/// thread, one chunk at a time in order (no nested parallelism). Workers that cannot be created
/// (the system's thread limit) leave their share to the others. The first exception a body
/// throws stops the handing out of chunks and is rethrown here once the running ones end.
/// Each calling thread has its own workers, created at its first call that needs them and
/// joined when it exits; several threads may call at once; a child of fork() starts workers of
/// its own (Python's multiprocessing). Preconditions: n >= 0, chunk >= 1.
template <class Body>
void ParallelFor(int threads, long n, long chunk, Body&& body) {
  parallel_detail::Run(
      threads, n, chunk,
      [](void* b, long begin, long end, int worker) {
        (*static_cast<std::remove_reference_t<Body>*>(b))(begin, end, worker);
      },
      const_cast<void*>(static_cast<const void*>(&body)));
}

}  // namespace aerovo
