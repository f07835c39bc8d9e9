// The typed state of `aerovo run` (pipeline/frame_loop.h): where a frame's height and camera
// attitude come from, what the lens pre-pass did, how the lens is undone, the flags a frame
// source sets, and how a run failed. Enums inside the run; their names (options::EnumTraits) are
// the text written to frames.csv, summary.json, config.json and the log, byte for byte as
// before they were enums.
#pragma once

#include <bitset>
#include <string>
#include <vector>

#include "aerovo/core/options.h"

namespace aerovo::run_steps {

/// Where a run takes the height above ground from (RunSummary::height_source, config.json
/// "resolved".height_source): RunConfig::altitude_m, the autopilot (MAVLink udpin/serial), or
/// the telemetry.
enum class HeightSource { kFlag, kMavlink, kTelemetry };
const char* ToString(HeightSource s);

/// Where one frame's height came from (FrameRecord::height_source, RunSummary::height_sources;
/// run_steps.h HeightProvider::HeightOf).
enum class FrameHeightSource {
  kNone,                    ///< "" (no height yet).
  kAltitudeFlag,            ///< "altitude_flag": RunConfig::altitude_m.
  kMavlinkDistanceSensor,   ///< "mavlink_distance_sensor": a downward rangefinder.
  kMavlinkRelativeAlt,      ///< "mavlink_relative_alt": GLOBAL_POSITION_INT.relative_alt.
  kTelemetry,               ///< "telemetry": the relative altitude.
  kTelemetryRelAltTakeoff,  ///< "telemetry_rel_alt+takeoff_height".
  kTelemetryAbsAltGround,   ///< "telemetry_abs_alt-ground_elevation".
  kLastKnown,               ///< "last_known": no height for the frame, the last one used.
  /// "first_record": a frame shortly before the telemetry's first record, given that record's
  /// height (RunTelemetry::FirstRecordAhead).
  kFirstRecord,
};
const char* ToString(FrameHeightSource s);

/// Where a frame's camera attitude came from (run_steps.h FrameAttitude::source,
/// RunSummary::attitude_sources).
enum class AttitudeSource {
  kNone,     ///< "" (no source has one).
  kGimbal,   ///< "gimbal": the telemetry's gimbal angles.
  kMavlink,  ///< "mavlink": the autopilot's ATTITUDE, camera fixed to the airframe.
  kFlight,   ///< "flight": the telemetry's aircraft angles, camera fixed.
  kMount,    ///< "mount": the camera mount's pitch, the aircraft taken as level.
  /// "estimated": the flight's own estimate (RunConfig::attitude_estimation), the same for every
  /// frame.
  kEstimated,
};
const char* ToString(AttitudeSource s);
/// The source in the attitude warning's words: "gimbal angles", "aircraft's angles",
/// "autopilot's ATTITUDE", "camera mount", "estimate from the flight".
const char* Describe(AttitudeSource s);

/// What the lens self-calibration pre-pass did (pipeline/lens_prepass.h LensPrepass::status);
/// kNotApplied: significant, but the run ended before its switch frame (pipeline/lens_switch.h).
enum class LensPrepassStatus {
  kApplied,
  kNotSignificant,
  kNoEstimate,
  kSkipped,
  kFailed,
  kNotApplied
};
const char* ToString(LensPrepassStatus s);

/// How the run undoes the lens distortion (RunSummary::undistortion): not at all, whole frames
/// remapped before SURF, or the keypoints (RunConfig::undistort resolved).
enum class UndistortionPath { kNone, kFrames, kPoints };
const char* ToString(UndistortionPath p);

/// A flag a frame source sets on a frame (frames/frame_source.h Frame::flags tokens).
enum class FrameFlag {
  kTruncated,  ///< "truncated": a photo file cut short, decoded with the missing part grey.
  kDuplicate,  ///< "duplicate": pixels identical to the frame before.
};
const char* ToString(FrameFlag f);

/// The flags of one frame: the known ones as a set, any other token a custom source sets by
/// name (in its order).
struct FrameFlags {
  std::bitset<2> known;             ///< Indexed by FrameFlag.
  std::vector<std::string> others;  ///< Tokens that are no FrameFlag.

  /// Frame::flags ('+'-separated tokens; empty tokens ignored).
  static FrameFlags Parse(const std::string& text);
  bool empty() const { return known.none() && others.empty(); }
  bool has(FrameFlag f) const { return known.test(static_cast<std::size_t>(f)); }
  /// Every flag's name: the known ones in FrameFlag order (the order the frame sources join
  /// them in), then the others.
  std::vector<std::string> Names() const;
  /// The names joined by '+' (the suffix of a flagged frame's status in frames.csv).
  std::string Text() const;
};

/// What ended a run early.
enum class RunFailureKind {
  kInput,   ///< An input error (InputError): a frame that cannot be read or used.
  kOutput,  ///< An output file that cannot be written (OutputError); the files stay valid.
};
const char* ToString(RunFailureKind k);

/// A run's failure, typed: the CLI and summary.json get Text().
struct RunFailure {
  RunFailureKind kind = RunFailureKind::kInput;
  int frame = -1;    ///< Frame::index of the frame it happened at; -1 before or after the frames.
  std::string file;  ///< The frame (Frame::name) its message is about; "" when it names it.
  std::string message;
  /// "file: message", or the message alone without a file: the text of summary.json "error".
  std::string Text() const { return file.empty() ? message : file + ": " + message; }
};

}  // namespace aerovo::run_steps

namespace aerovo {
template <>
struct options::EnumTraits<run_steps::HeightSource>
    : options::EnumList<run_steps::HeightSource, run_steps::ToString,
                        run_steps::HeightSource::kFlag, run_steps::HeightSource::kMavlink,
                        run_steps::HeightSource::kTelemetry> {};
template <>
struct options::EnumTraits<run_steps::FrameHeightSource>
    : options::EnumList<run_steps::FrameHeightSource, run_steps::ToString,
                        run_steps::FrameHeightSource::kNone,
                        run_steps::FrameHeightSource::kAltitudeFlag,
                        run_steps::FrameHeightSource::kMavlinkDistanceSensor,
                        run_steps::FrameHeightSource::kMavlinkRelativeAlt,
                        run_steps::FrameHeightSource::kTelemetry,
                        run_steps::FrameHeightSource::kTelemetryRelAltTakeoff,
                        run_steps::FrameHeightSource::kTelemetryAbsAltGround,
                        run_steps::FrameHeightSource::kLastKnown> {};
template <>
struct options::EnumTraits<run_steps::AttitudeSource>
    : options::EnumList<run_steps::AttitudeSource, run_steps::ToString,
                        run_steps::AttitudeSource::kNone, run_steps::AttitudeSource::kGimbal,
                        run_steps::AttitudeSource::kMavlink, run_steps::AttitudeSource::kFlight,
                        run_steps::AttitudeSource::kMount,
                        run_steps::AttitudeSource::kEstimated> {};
template <>
struct options::EnumTraits<run_steps::LensPrepassStatus>
    : options::EnumList<
          run_steps::LensPrepassStatus, run_steps::ToString, run_steps::LensPrepassStatus::kApplied,
          run_steps::LensPrepassStatus::kNotSignificant, run_steps::LensPrepassStatus::kNoEstimate,
          run_steps::LensPrepassStatus::kSkipped, run_steps::LensPrepassStatus::kFailed,
          run_steps::LensPrepassStatus::kNotApplied> {};
template <>
struct options::EnumTraits<run_steps::UndistortionPath>
    : options::EnumList<run_steps::UndistortionPath, run_steps::ToString,
                        run_steps::UndistortionPath::kNone, run_steps::UndistortionPath::kFrames,
                        run_steps::UndistortionPath::kPoints> {};
template <>
struct options::EnumTraits<run_steps::FrameFlag>
    : options::EnumList<run_steps::FrameFlag, run_steps::ToString, run_steps::FrameFlag::kTruncated,
                        run_steps::FrameFlag::kDuplicate> {};
template <>
struct options::EnumTraits<run_steps::RunFailureKind>
    : options::EnumList<run_steps::RunFailureKind, run_steps::ToString,
                        run_steps::RunFailureKind::kInput, run_steps::RunFailureKind::kOutput> {};
}  // namespace aerovo
