#include "aerovo/cli/progress.h"

#include <unistd.h>

#include <algorithm>

#include <fmt/format.h>

namespace aerovo::cli {
namespace {

std::string Eta(int done, int expected, double fps) {
  const double eta = fps > 0 ? (expected - done) / fps : 0.0;
  return fmt::format("{}:{:02d}", static_cast<int>(eta) / 60, static_cast<int>(eta) % 60);
}

}  // namespace

ProgressStyle DefaultProgressStyle(bool quiet) {
  if (quiet) return ProgressStyle::kOff;
  return ::isatty(STDERR_FILENO) != 0 ? ProgressStyle::kBar : ProgressStyle::kLines;
}

Progress::Progress(ProgressStyle style, std::FILE* out, double line_interval_s)
    : style_(style), out_(out), line_interval_s_(line_interval_s) {}

Progress::~Progress() { Finish(); }

void Progress::Update(int done, int expected, double fps, const std::string& prefix) {
  if (style_ == ProgressStyle::kOff) return;
  if (style_ == ProgressStyle::kBar) {
    std::string line;
    if (expected > 0) {
      const int width = 30;
      const int filled = std::clamp(done * width / expected, 0, width);
      line = fmt::format("\r{}[{}{}] {:>5}/{:<5} {:6.2f} fps  ETA {} ", prefix,
                         std::string(filled, '#'), std::string(width - filled, '.'), done, expected,
                         fps, Eta(done, expected, fps));
    } else {
      line = fmt::format("\r{}{:>6} frames {:6.2f} fps ", prefix, done, fps);
    }
    std::fputs(line.c_str(), out_);
    std::fflush(out_);
    open_ = true;
    return;
  }
  std::string line = prefix;
  if (expected > 0) {
    line += fmt::format("{}/{} frames", done, expected);
  } else {
    line += fmt::format("{} frames", done);
  }
  if (fps > 0) line += fmt::format(", {:.2f} fps", fps);
  if (fps > 0 && expected > 0) line += ", ETA " + Eta(done, expected, fps);
  line += '\n';
  const bool due = !open_ || last_line_.elapsed_ms() >= 1000.0 * line_interval_s_;
  open_ = true;
  if (due) {
    std::fputs(line.c_str(), out_);
    std::fflush(out_);
    last_line_.restart();
    printed_last_ = true;
  } else {
    printed_last_ = false;
    last_line_text_ = std::move(line);
  }
}

void Progress::Update(int done, int expected, const std::string& prefix) {
  const double s = started_.elapsed_ms() / 1000.0;
  Update(done, expected, s > 0 ? done / s : 0.0, prefix);
}

void Progress::End(bool erase) {
  if (open_) {
    if (style_ == ProgressStyle::kBar) {
      std::fputs(erase ? "\r\033[K" : "\n", out_);
    } else if (!printed_last_) {
      std::fputs(last_line_text_.c_str(), out_);
    }
    std::fflush(out_);
  }
  open_ = false;
  printed_last_ = false;
  last_line_text_.clear();
  started_.restart();
}

void Progress::Finish() { End(false); }
void Progress::Clear() { End(true); }

}  // namespace aerovo::cli
