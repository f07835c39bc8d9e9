#include "aerovo/io/prefetch_source.h"

#include <utility>

#include "aerovo/core/error.h"
#include "aerovo/core/timer.h"

namespace aerovo {

PrefetchSource::PrefetchSource(std::unique_ptr<FrameSource> inner, const PrefetchOptions& options)
    : inner_(std::move(inner)), options_(options) {
  if (!inner_) throw InvalidArgument("PrefetchSource: the inner frame source is null");
  if (options_.capacity < 1) {
    throw InvalidArgument("PrefetchSource: capacity must be >= 1, got " +
                          std::to_string(options_.capacity));
  }
  description_ = inner_->Describe();
  expected_ = inner_->ExpectedFrameCount();
  live_ = inner_->IsLive();
}

PrefetchSource::~PrefetchSource() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  changed_.notify_all();
  if (reader_.joinable()) reader_.join();
}

void PrefetchSource::ReadLoop() {
  Frame spare;
  std::size_t warnings_seen = 0;
  while (true) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      if (options_.policy == QueuePolicy::kWait) {
        changed_.wait(lock, [&] {
          return stop_ || static_cast<int>(queue_.size()) < options_.capacity;
        });
      }
      if (stop_) return;
    }
    bool more = false;
    std::exception_ptr error;
    try {
      more = inner_->Next(spare);
    } catch (...) {
      error = std::current_exception();
    }
    const double received_s = SteadySeconds();
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      const std::vector<std::string>& w = inner_->warnings();
      for (; warnings_seen < w.size(); ++warnings_seen) new_warnings_.push_back(w[warnings_seen]);
      if (error || !more) {
        error_ = error;
        end_ = true;
      } else {
        spare.received_s = received_s;
        if (static_cast<int>(queue_.size()) >= options_.capacity) {  // kDropOldest only
          pool_.push_back(std::move(queue_.front()));
          queue_.pop_front();
          dropped_.fetch_add(1);
        }
        queue_.push_back(std::move(spare));
        if (!pool_.empty()) {
          spare = std::move(pool_.back());
          pool_.pop_back();
        } else {
          spare = Frame();
        }
      }
    }
    changed_.notify_all();
    if (error || !more) return;
  }
}

bool PrefetchSource::Next(Frame& frame) {
  if (!reader_.joinable()) reader_ = std::thread([this] { ReadLoop(); });
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait(lock, [&] { return !queue_.empty() || end_; });
  for (std::string& w : new_warnings_) warnings_.push_back(std::move(w));
  new_warnings_.clear();
  if (!queue_.empty()) {
    std::swap(frame, queue_.front());
    pool_.push_back(std::move(queue_.front()));  // the caller's previous frame, for reuse
    queue_.pop_front();
    lock.unlock();
    changed_.notify_all();
    return true;
  }
  if (error_) {
    std::exception_ptr e = error_;
    error_ = nullptr;  // thrown once; later calls return false
    std::rethrow_exception(e);
  }
  return false;
}

}  // namespace aerovo
