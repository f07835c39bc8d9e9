// The one progress display of every command (run, experiment, demo, simulate), on stderr. On a
// terminal: one line redrawn in place, "[#####.....]  45/172    3.20 fps  ETA 0:40". Elsewhere
// (a log file, CI): no carriage returns, a plain line every few seconds,
// "45/172 frames, 3.20 fps, ETA 0:40", so that the log shows the run moving.
#pragma once

#include <cstdio>
#include <string>

#include "aerovo/core/timer.h"

namespace aerovo::cli {

enum class ProgressStyle {
  kBar,    ///< A terminal: one line redrawn in place ("\r").
  kLines,  ///< Not a terminal: a plain line at most every line_interval_s, and the last state.
  kOff,    ///< Nothing (--quiet, or stderr carries something else).
};

/// kOff when `quiet`, else kBar when stderr is a terminal, else kLines.
ProgressStyle DefaultProgressStyle(bool quiet);

class Progress {
 public:
  /// Seconds between two plain lines (kLines): often enough to see a run move in a log, rare
  /// enough that an hour-long run writes ~700 lines.
  static constexpr double kDefaultLineIntervalS = 5.0;

  explicit Progress(ProgressStyle style, std::FILE* out = stderr,
                    double line_interval_s = kDefaultLineIntervalS);
  /// Finish()es a display left open.
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  ProgressStyle style() const { return style_; }
  bool enabled() const { return style_ != ProgressStyle::kOff; }

  /// `done` of `expected` items (frames; expected <= 0: unknown) at `fps` items per second
  /// (<= 0: unknown, no ETA); `prefix` is printed first (e.g. "run 2/5 k=0.75 ").
  void Update(int done, int expected, double fps, const std::string& prefix = "");
  /// Same with the rate measured since the display started (construction or the last
  /// Finish/Clear): for callers that count items but do not time them.
  void Update(int done, int expected, const std::string& prefix);

  /// Ends the current display: the bar stays on screen and the cursor moves to the next line;
  /// in kLines the last state is printed unless it already was. No-op when nothing is shown.
  void Finish();
  /// Ends the current display and erases the bar (kBar), before other output takes the line;
  /// in kLines like Finish().
  void Clear();

 private:
  void End(bool erase);

  ProgressStyle style_;
  std::FILE* out_;
  double line_interval_s_;
  Stopwatch started_;          // since the display started (for Update without fps)
  Stopwatch last_line_;        // since the last plain line (kLines)
  bool open_ = false;          // something shown since the display started
  bool printed_last_ = false;  // kLines: the last Update's state was printed
  std::string last_line_text_;
};

}  // namespace aerovo::cli
