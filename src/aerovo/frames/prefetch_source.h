// Decoding on its own thread: a FrameSource wrapper whose reader thread pulls frames from any
// other FrameSource into a bounded queue, so that decoding frame n+1 overlaps the processing of
// frame n. For a live source the queue is where latency is bounded: when frames arrive faster
// than they are taken, the oldest queued frame is dropped (counted) and the newest kept.
#pragma once

#include <atomic>
#include <condition_variable>
#include <deque>
#include <exception>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "aerovo/frames/frame_source.h"

namespace aerovo {

/// What the reader does when the queue is full.
enum class QueuePolicy {
  /// Wait for the consumer: every frame is delivered, in order (files: video, photos).
  kWait,
  /// Keep reading; the oldest queued frame is dropped and counted (live cameras and streams:
  /// the consumer always gets the newest frame, latency stays bounded).
  kDropOldest,
};

struct PrefetchOptions {
  /// Frames held decoded ahead, >= 1. 2 (default) lets decoding overlap processing with one
  /// frame to spare; a live source is best served with 1 (only the newest frame waits).
  int capacity = 2;
  QueuePolicy policy = QueuePolicy::kWait;
  /// How long the destructor waits for an `inner.Next()` in progress before it leaves the
  /// reader to finish that one read on its own, ms; < 0: wait for it however long it takes.
  /// A stop must not wait for the next frame's decoding: a 20000x20000 photo's takes seconds,
  /// a live stream's read can block until its timeout (docs/reliability.md, "SIGINT inside a huge
  /// frame": a stop within a second).
  int join_timeout_ms = 100;
};

/// Reads `inner` on a reader thread started by the first Next(). Delivers the frames of `inner`
/// in their order (with kDropOldest: a subsequence, the dropped ones counted in dropped()), each
/// with Frame::received_s set when `inner` delivered it. End of `inner` -> Next() returns false
/// once the queue is drained. An exception thrown by `inner` (e.g. InputError naming the frame)
/// is rethrown by the Next() after the frames queued before it, unchanged (same type and
/// message). `inner`'s warnings() appear in this source's warnings() as Next() is called.
/// Describe(), ExpectedFrameCount() and IsLive() are `inner`'s, read at construction.
/// Next() hands out frames by swapping: the Frame passed in goes back to the pool, so no frame
/// buffer is allocated once the queue is warm. Next() is called from one thread at a time.
/// The destructor stops the reader and joins it; when the reader is inside an `inner.Next()`
/// that does not return within `join_timeout_ms`, the reader is detached instead: it finishes
/// that read, drops the frame and ends, and `inner` is destroyed then, on the reader's thread
/// (the reader holds the shared state, so nothing it touches is freed under it).
class PrefetchSource : public FrameSource {
 public:
  /// InvalidArgument for a null `inner` or capacity < 1.
  PrefetchSource(std::unique_ptr<FrameSource> inner, const PrefetchOptions& options = {});
  ~PrefetchSource() override;
  PrefetchSource(const PrefetchSource&) = delete;
  PrefetchSource& operator=(const PrefetchSource&) = delete;

  bool Next(Frame& frame) override;
  std::string Describe() const override { return description_; }
  int ExpectedFrameCount() const override { return expected_; }
  bool IsLive() const override { return live_; }

  /// Frames dropped so far by kDropOldest (read by `inner`, never delivered).
  int dropped() const;
  /// The wrapped source (its const accessors that do not change while it is read, e.g. an
  /// ImageFolderSource's metadata(), may be used from any thread).
  const FrameSource& inner() const;
  const PrefetchOptions& options() const;

 private:
  struct State;  // what the reader thread touches, shared with it (it may outlive *this)
  static void ReadLoop(const std::shared_ptr<State>& state);

  std::shared_ptr<State> state_;
  std::string description_;
  int expected_ = -1;
  bool live_ = false;
  std::thread reader_;
};

}  // namespace aerovo
