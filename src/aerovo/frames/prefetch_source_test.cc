#include "aerovo/frames/prefetch_source.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <mutex>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "aerovo/core/error.h"

namespace aerovo::prefetch_source_test {
namespace {

// Frames 0..count-1 of 32x24 px whose pixels encode the index; optionally slow, throwing at
// `throw_at`, or endless (count < 0). Counts what it produced (for the test thread).
class CountingSource : public FrameSource {
 public:
  explicit CountingSource(int count, std::chrono::microseconds delay = {}, int throw_at = -1)
      : count_(count), delay_(delay), throw_at_(throw_at) {}
  bool Next(Frame& frame) override {
    if (count_ >= 0 && next_ >= count_) {
      finished_.store(true);
      return false;
    }
    if (next_ == throw_at_) throw InputError("frame " + std::to_string(next_) + ": broken");
    if (delay_.count() > 0) std::this_thread::sleep_for(delay_);
    if (frame.gray.width() != 32) frame.gray = GrayImage(32, 24);
    for (int y = 0; y < 24; ++y) {
      for (int x = 0; x < 32; ++x) frame.gray.row(y)[x] = static_cast<std::uint8_t>(next_ * 7 + x + y);
    }
    frame.index = next_;
    frame.time_s = 0.1 * next_;
    frame.name = "f" + std::to_string(next_);
    if (next_ == 3) warnings_.push_back("frame 3 is odd");
    ++next_;
    produced_.store(next_);
    return true;
  }
  std::string Describe() const override { return "counting source"; }
  int ExpectedFrameCount() const override { return count_; }

  std::atomic<int> produced_{0};
  std::atomic<bool> finished_{false};

 private:
  int count_;
  std::chrono::microseconds delay_;
  int throw_at_;
  int next_ = 0;
};

bool PixelsOf(const Frame& f, int index) {
  for (int y = 0; y < 24; ++y) {
    for (int x = 0; x < 32; ++x) {
      if (f.gray.row(y)[x] != static_cast<std::uint8_t>(index * 7 + x + y)) return false;
    }
  }
  return true;
}

TEST(PrefetchSource, SameFramesInTheSameOrderAsWithout) {
  CountingSource direct(40);
  std::vector<Frame> want;
  Frame f;
  while (direct.Next(f)) want.push_back(f);
  ASSERT_EQ(want.size(), 40u);

  auto inner = std::make_unique<CountingSource>(40);
  PrefetchSource p(std::move(inner), {2, QueuePolicy::kWait});
  EXPECT_EQ(p.Describe(), "counting source");
  EXPECT_EQ(p.ExpectedFrameCount(), 40);
  Frame g;
  std::size_t n = 0;
  double last_received = -1e300;
  while (p.Next(g)) {
    ASSERT_LT(n, want.size());
    EXPECT_EQ(g.index, want[n].index);
    EXPECT_EQ(g.time_s, want[n].time_s);
    EXPECT_EQ(g.name, want[n].name);
    EXPECT_TRUE(PixelsOf(g, want[n].index)) << n;
    ASSERT_TRUE(std::isfinite(g.received_s));
    EXPECT_GE(g.received_s, last_received);
    last_received = g.received_s;
    ++n;
  }
  EXPECT_EQ(n, 40u);
  EXPECT_FALSE(p.Next(g)) << "end of stream stays the end";
  EXPECT_EQ(p.dropped(), 0);
  ASSERT_EQ(p.warnings().size(), 1u);
  EXPECT_EQ(p.warnings()[0], "frame 3 is odd");
}

TEST(PrefetchSource, WaitPolicyIsBoundedAndDropsNothingForASlowConsumer) {
  auto inner = std::make_unique<CountingSource>(30);
  CountingSource* src = inner.get();
  PrefetchSource p(std::move(inner), {2, QueuePolicy::kWait});
  Frame f;
  int taken = 0, max_ahead = 0;
  while (p.Next(f)) {
    EXPECT_EQ(f.index, taken);
    ++taken;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    // Produced but not taken: the queue (2) and the frame the reader holds ready to push (1).
    max_ahead = std::max(max_ahead, src->produced_.load() - taken);
  }
  EXPECT_EQ(taken, 30);
  EXPECT_EQ(p.dropped(), 0);
  EXPECT_LE(max_ahead, 3);
  EXPECT_GE(max_ahead, 1) << "nothing was decoded ahead";
}

TEST(PrefetchSource, DropOldestHandsOutTheNewestFrame) {
  auto inner = std::make_unique<CountingSource>(50);
  CountingSource* src = inner.get();
  PrefetchSource p(std::move(inner), {1, QueuePolicy::kDropOldest});
  Frame f;
  ASSERT_TRUE(p.Next(f));
  int delivered = 1;
  // The source runs to its end while the consumer is busy: only the newest frame is kept.
  while (!src->finished_.load()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  if (f.index != 49) {  // (the first frame is 49 only if this thread slept through the run)
    ASSERT_TRUE(p.Next(f));
    ++delivered;
    EXPECT_EQ(f.index, 49);
    EXPECT_TRUE(PixelsOf(f, 49));
  }
  EXPECT_FALSE(p.Next(f));
  EXPECT_EQ(p.dropped(), 50 - delivered) << "every frame is either delivered or dropped";
}

TEST(PrefetchSource, DropOldestUnderASlowConsumerCountsEveryFrame) {
  auto inner = std::make_unique<CountingSource>(120, std::chrono::microseconds(500));
  PrefetchSource p(std::move(inner), {1, QueuePolicy::kDropOldest});
  Frame f;
  std::vector<int> got;
  while (p.Next(f)) {
    if (!got.empty()) {
      EXPECT_GT(f.index, got.back());
    }
    EXPECT_TRUE(PixelsOf(f, f.index));
    got.push_back(f.index);
    std::this_thread::sleep_for(std::chrono::milliseconds(3));  // 6x slower than the source
  }
  ASSERT_FALSE(got.empty());
  EXPECT_EQ(got.back(), 119) << "the last frame is the newest: it is never dropped";
  EXPECT_EQ(static_cast<int>(got.size()) + p.dropped(), 120);
  EXPECT_GT(p.dropped(), 0);
}

TEST(PrefetchSource, AnErrorIsRethrownAfterTheFramesBeforeIt) {
  auto inner = std::make_unique<CountingSource>(20, std::chrono::microseconds(0), 5);
  PrefetchSource p(std::move(inner));
  Frame f;
  for (int i = 0; i < 5; ++i) {
    ASSERT_TRUE(p.Next(f));
    EXPECT_EQ(f.index, i);
  }
  try {
    p.Next(f);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "frame 5: broken");
  }
  EXPECT_FALSE(p.Next(f));
}

TEST(PrefetchSource, AnErrorAtTheFirstFrameIsThrownByTheFirstNext) {
  PrefetchSource p(std::make_unique<CountingSource>(20, std::chrono::microseconds(0), 0));
  Frame f;
  EXPECT_THROW(p.Next(f), InputError);
}

// A CountingSource that reports, to a probe the test owns, how many frames it produced and
// whether it was destroyed (the probe outlives it).
struct SourceProbe {
  std::atomic<int> produced{0};
  std::atomic<bool> destroyed{false};
};
class ProbedSource : public CountingSource {
 public:
  ProbedSource(std::shared_ptr<SourceProbe> probe, int count, std::chrono::microseconds delay)
      : CountingSource(count, delay), probe_(std::move(probe)) {}
  ~ProbedSource() override { probe_->destroyed.store(true); }
  bool Next(Frame& frame) override {
    const bool more = CountingSource::Next(frame);
    probe_->produced.store(produced_.load());
    return more;
  }

 private:
  std::shared_ptr<SourceProbe> probe_;
};

// Waits up to 5 s for `pred`; true when it held.
template <typename Pred>
bool WaitFor(Pred pred) {
  for (int i = 0; i < 5000 && !pred(); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  return pred();
}

// The destructor stops and joins a reader that is blocked waiting for room in a full queue
// (kWait) and one that is reading frame after frame (kDropOldest, endless source): it returns
// promptly, the reader reads nothing more, and the inner source is destroyed with the wrapper.
TEST(PrefetchSource, DestroyedWhileTheReaderWaitsOrReads) {
  for (const QueuePolicy policy : {QueuePolicy::kWait, QueuePolicy::kDropOldest}) {
    SCOPED_TRACE(policy == QueuePolicy::kWait ? "kWait" : "kDropOldest");
    auto probe = std::make_shared<SourceProbe>();
    std::chrono::steady_clock::time_point destroying;
    {
      // join_timeout_ms -1: the destructor joins the reader (it never leaves it running), so
      // a reader that did not see the stop would hang here instead of passing.
      PrefetchSource p(std::make_unique<ProbedSource>(probe, -1, std::chrono::microseconds(200)),
                       {2, policy, -1});
      Frame f;
      ASSERT_TRUE(p.Next(f));
      if (policy == QueuePolicy::kWait) {
        // 1 taken + 2 queued: then the reader waits for room before it reads again.
        ASSERT_TRUE(WaitFor([&] { return probe->produced.load() >= 3; }));
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        EXPECT_EQ(probe->produced.load(), 3) << "the reader is waiting, not reading";
      } else {
        // The newest frame replaces the queued one: the reader keeps reading.
        ASSERT_TRUE(WaitFor([&] { return probe->produced.load() >= 20; }));
      }
      EXPECT_FALSE(probe->destroyed.load());
      destroying = std::chrono::steady_clock::now();
    }
    const double destroy_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - destroying).count();
    EXPECT_TRUE(probe->destroyed.load()) << "joined: the inner source went with the wrapper";
    EXPECT_LT(destroy_s, 2.0) << "the reader saw the stop within one 200 us read";
  }
  // A wrapper whose frames are never asked for starts no reader: nothing is read.
  auto unread = std::make_shared<SourceProbe>();
  {
    PrefetchSource never_read(
        std::make_unique<ProbedSource>(unread, 3, std::chrono::microseconds(0)),
        {2, QueuePolicy::kWait, -1});
  }
  EXPECT_TRUE(unread->destroyed.load());
  EXPECT_EQ(unread->produced.load(), 0);
}

// A source whose second Next() blocks until the test opens the gate (a huge photo's decoding,
// a stream's read timeout); it records its destruction in a flag the test owns.
class GatedSource : public FrameSource {
 public:
  struct Shared {
    std::mutex mutex;
    std::condition_variable cv;
    bool open = false, inside = false;
    std::atomic<bool> destroyed{false};
  };
  explicit GatedSource(std::shared_ptr<Shared> shared) : shared_(std::move(shared)) {}
  ~GatedSource() override { shared_->destroyed.store(true); }
  bool Next(Frame& frame) override {
    if (next_ > 0) {
      std::unique_lock<std::mutex> lock(shared_->mutex);
      shared_->inside = true;
      shared_->cv.notify_all();
      shared_->cv.wait(lock, [&] { return shared_->open; });
    }
    frame.gray = GrayImage(8, 8);
    frame.index = next_++;
    return true;
  }
  std::string Describe() const override { return "gated source"; }
  int ExpectedFrameCount() const override { return -1; }

 private:
  std::shared_ptr<Shared> shared_;
  int next_ = 0;
};

TEST(PrefetchSource, DestructionDoesNotWaitForAReadInProgressBeyondItsTimeout) {
  auto shared = std::make_shared<GatedSource::Shared>();
  {
    PrefetchSource p(std::make_unique<GatedSource>(shared), {2, QueuePolicy::kWait, 20});
    Frame f;
    ASSERT_TRUE(p.Next(f));
    std::unique_lock<std::mutex> lock(shared->mutex);
    shared->cv.wait(lock, [&] { return shared->inside; });  // the reader is in the blocked read
  }  // returns although the read has not: the reader was left to finish it
  EXPECT_FALSE(shared->destroyed.load());  // the reader still owns the inner source
  {
    const std::lock_guard<std::mutex> lock(shared->mutex);
    shared->open = true;
  }
  shared->cv.notify_all();
  for (int i = 0; i < 5000 && !shared->destroyed.load(); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  EXPECT_TRUE(shared->destroyed.load());  // once the read returned, the reader ended and freed it

  // join_timeout_ms < 0: the destructor waits for the read.
  auto waited = std::make_shared<GatedSource::Shared>();
  std::thread opener;
  {
    PrefetchSource p(std::make_unique<GatedSource>(waited), {2, QueuePolicy::kWait, -1});
    Frame f;
    ASSERT_TRUE(p.Next(f));
    {
      std::unique_lock<std::mutex> lock(waited->mutex);
      waited->cv.wait(lock, [&] { return waited->inside; });
    }
    opener = std::thread([&] {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      const std::lock_guard<std::mutex> lock(waited->mutex);
      waited->open = true;
      waited->cv.notify_all();
    });
  }
  EXPECT_TRUE(waited->destroyed.load());  // joined: the inner source went with the wrapper
  opener.join();
}

TEST(PrefetchSource, RejectsANullSourceAndAZeroCapacity) {
  EXPECT_THROW(PrefetchSource(nullptr), InvalidArgument);
  EXPECT_THROW(PrefetchSource(std::make_unique<CountingSource>(3), {0, QueuePolicy::kWait}),
               InvalidArgument);
}

}  // namespace
}  // namespace aerovo::prefetch_source_test
