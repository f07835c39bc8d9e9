#include "aerovo/pipeline/run_types.h"

#include <algorithm>

#include "aerovo/frames/frame_source.h"

namespace aerovo::run_steps {

const char* ToString(HeightSource s) {
  switch (s) {
    case HeightSource::kFlag:
      return "flag";
    case HeightSource::kMavlink:
      return "mavlink";
    case HeightSource::kTelemetry:
      return "telemetry";
  }
  return "?";
}

const char* ToString(FrameHeightSource s) {
  switch (s) {
    case FrameHeightSource::kNone:
      return "";
    case FrameHeightSource::kAltitudeFlag:
      return "altitude_flag";
    case FrameHeightSource::kMavlinkDistanceSensor:
      return "mavlink_distance_sensor";
    case FrameHeightSource::kMavlinkRelativeAlt:
      return "mavlink_relative_alt";
    case FrameHeightSource::kTelemetry:
      return "telemetry";
    case FrameHeightSource::kTelemetryRelAltTakeoff:
      return "telemetry_rel_alt+takeoff_height";
    case FrameHeightSource::kTelemetryAbsAltGround:
      return "telemetry_abs_alt-ground_elevation";
    case FrameHeightSource::kLastKnown:
      return "last_known";
    case FrameHeightSource::kFirstRecord:
      return "first_record";
  }
  return "?";
}

const char* ToString(AttitudeSource s) {
  switch (s) {
    case AttitudeSource::kNone:
      return "";
    case AttitudeSource::kGimbal:
      return "gimbal";
    case AttitudeSource::kMavlink:
      return "mavlink";
    case AttitudeSource::kFlight:
      return "flight";
    case AttitudeSource::kMount:
      return "mount";
    case AttitudeSource::kEstimated:
      return "estimated";
  }
  return "?";
}

const char* Describe(AttitudeSource s) {
  switch (s) {
    case AttitudeSource::kGimbal:
      return "gimbal angles";
    case AttitudeSource::kFlight:
      return "aircraft's angles";
    case AttitudeSource::kMavlink:
      return "autopilot's ATTITUDE";
    case AttitudeSource::kEstimated:
      return "estimate from the flight";
    case AttitudeSource::kMount:
    case AttitudeSource::kNone:
      return "camera mount";
  }
  return "camera mount";
}

const char* ToString(LensPrepassStatus s) {
  switch (s) {
    case LensPrepassStatus::kApplied:
      return "applied";
    case LensPrepassStatus::kNotSignificant:
      return "not significant";
    case LensPrepassStatus::kNoEstimate:
      return "no estimate";
    case LensPrepassStatus::kSkipped:
      return "skipped";
    case LensPrepassStatus::kFailed:
      return "failed";
    case LensPrepassStatus::kNotApplied:
      return "not applied";
  }
  return "?";
}

const char* ToString(UndistortionPath p) {
  switch (p) {
    case UndistortionPath::kNone:
      return "none";
    case UndistortionPath::kFrames:
      return "frames";
    case UndistortionPath::kPoints:
      return "points";
  }
  return "?";
}

const char* ToString(FrameFlag f) {
  return f == FrameFlag::kTruncated ? kFrameFlagTruncated : kFrameFlagDuplicate;
}

const char* ToString(RunFailureKind k) { return k == RunFailureKind::kInput ? "input" : "output"; }

FrameFlags FrameFlags::Parse(const std::string& text) {
  FrameFlags out;
  std::size_t b = 0;
  while (b <= text.size()) {
    const std::size_t e = std::min(text.find('+', b), text.size());
    const std::string token = text.substr(b, e - b);
    b = e + 1;
    if (token.empty()) continue;
    if (const auto known = options::ParseEnum<FrameFlag>(token)) {
      out.known.set(static_cast<std::size_t>(*known));
    } else if (std::find(out.others.begin(), out.others.end(), token) == out.others.end()) {
      out.others.push_back(token);
    }
  }
  return out;
}

std::vector<std::string> FrameFlags::Names() const {
  std::vector<std::string> out;
  for (const FrameFlag f : options::EnumTraits<FrameFlag>::kValues) {
    if (has(f)) out.emplace_back(ToString(f));
  }
  out.insert(out.end(), others.begin(), others.end());
  return out;
}

std::string FrameFlags::Text() const {
  std::string out;
  for (const std::string& n : Names()) out += (out.empty() ? "" : "+") + n;
  return out;
}

}  // namespace aerovo::run_steps
