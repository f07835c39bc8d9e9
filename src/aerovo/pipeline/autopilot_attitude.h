// The autopilot's ATTITUDE for each frame of a run that reads an autopilot link (udpin/serial).
#pragma once

#include <optional>

#include "aerovo/mavlink/link.h"

namespace aerovo::run_steps {

/// Matches frames with the link's ATTITUDE samples: the sample nearest the frame's capture time
/// (MonotonicNowS clock) within `match_s` (RunConfig::mavlink_match_s); until a sample has
/// matched a frame, when none is that close, the newest one within `match_s` of now. The run
/// reads its first frame before it waits for the link's first sample (run_setup.cc SetUpHeight,
/// mavlink_wait_s), so the first frame's capture time may precede every sample: the same rule as
/// the first frame's height (run_steps.h HeightProvider::HeightOf).
class AutopilotAttitudeMatcher {
 public:
  /// `link` not null, alive while this is used.
  AutopilotAttitudeMatcher(const mavlink::AutopilotLink* link, double match_s)
      : link_(link), match_s_(match_s) {}
  std::optional<mavlink::AutopilotAttitude> AttitudeOf(double capture_s) {
    std::optional<mavlink::AutopilotAttitude> a = link_->AttitudeNear(capture_s, match_s_);
    if (!a && !matched_) a = link_->AttitudeNear(mavlink::MonotonicNowS(), match_s_);
    matched_ = matched_ || a.has_value();
    return a;
  }

 private:
  const mavlink::AutopilotLink* link_;
  double match_s_;
  bool matched_ = false;  // a sample has matched a frame
};

}  // namespace aerovo::run_steps
