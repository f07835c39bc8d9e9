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

#include "aerovo/io/frame_source.h"

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
/// The destructor stops the reader and joins it (it waits for an `inner.Next()` in progress,
/// e.g. a live stream's read timeout).
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
  int dropped() const { return dropped_.load(); }
  /// The wrapped source (its const accessors that do not change while it is read, e.g. an
  /// ImageFolderSource's metadata(), may be used from any thread).
  const FrameSource& inner() const { return *inner_; }
  const PrefetchOptions& options() const { return options_; }

 private:
  void ReadLoop();

  std::unique_ptr<FrameSource> inner_;
  PrefetchOptions options_;
  std::string description_;
  int expected_ = -1;
  bool live_ = false;

  std::mutex mutex_;
  std::condition_variable changed_;  // queue, end, error or stop changed
  std::deque<Frame> queue_;          // decoded, oldest first
  std::vector<Frame> pool_;          // frames whose buffers are reused by the reader
  std::vector<std::string> new_warnings_;  // inner's warnings not yet moved to warnings_
  bool end_ = false;                       // inner ended (or threw: error_)
  bool stop_ = false;                      // destructor: reader must quit
  std::exception_ptr error_;
  std::atomic<int> dropped_{0};
  std::thread reader_;
};

}  // namespace aerovo
