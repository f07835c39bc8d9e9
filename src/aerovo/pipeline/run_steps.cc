#include "aerovo/pipeline/run_steps.h"
#include "aerovo/core/angles.h"
#include "aerovo/core/cancel.h"
#include "aerovo/outputs/output_file.h"

#include <signal.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iostream>
#include <limits>
#include <system_error>
#include <utility>

#include <fmt/format.h>
#include <Eigen/LU>
#include <nlohmann/json.hpp>

#include "aerovo/camera/lens.h"
#include "aerovo/camera_files/calibration.h"
#include "aerovo/core/error.h"
#include "aerovo/frames/camera.h"
#include "aerovo/frames/video_text_track.h"
#include "aerovo/pipeline/lens_prepass.h"
#include "aerovo/pipeline/pose_quality.h"
#include "aerovo/report/run_reader.h"  // AssociateWithTruth
#include "aerovo/sim/sim_writer.h"
#include "aerovo/telemetry/telemetry_readers.h"

namespace aerovo::run_steps {

std::optional<GeoPoint> GpsOf(const std::optional<TelemetrySample>& s) {
  if (!s || !s->has_fix) return std::nullopt;
  GeoPoint p;
  p.lat_deg = s->lat_deg;
  p.lon_deg = s->lon_deg;
  p.alt_m = s->abs_alt_m.value_or(s->rel_alt_m.value_or(0.0));
  return p;
}

// ---------------------------------------------------------------------------------------------
// 1. Inputs

namespace {

// The sim.json of `aerovo simulate` when `input` is its video or frames folder (sim.json sits in
// the folder above either). An unreadable or foreign sim.json is reported and ignored.
std::optional<sim::SimulationManifest> FindSimulationManifest(const std::string& input,
                                                              std::vector<std::string>* warnings) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::path in = fs::path(input).lexically_normal();
  if (!in.has_filename()) in = in.parent_path();                  // "frames/" -> "frames"
  if (input.empty() || !fs::exists(in, ec)) return std::nullopt;  // live source
  const fs::path dir = in.has_parent_path() ? in.parent_path() : fs::path(".");
  const fs::path json = dir / "sim.json";
  if (!fs::is_regular_file(json, ec)) return std::nullopt;
  try {
    sim::SimulationManifest m = sim::ReadSimulationManifest(json);
    const bool same_video = !m.video.empty() && fs::equivalent(in, m.video, ec);
    const bool same_frames = !m.frames_dir.empty() && fs::equivalent(in, m.frames_dir, ec);
    if (same_video || same_frames) return m;
  } catch (const InputError& e) {
    warnings->push_back(std::string("ignored ") + json.string() + ": " + e.what());
  }
  return std::nullopt;
}

// The .SRT of the same name beside the video file `input` (DJI_0042.MP4 -> DJI_0042.SRT, the
// extension in any case), if there is exactly one; "" otherwise (a folder, a live source).
std::string TelemetryBeside(const std::string& input) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path video(input);
  if (input.empty() || !fs::is_regular_file(video, ec)) return "";
  const fs::path dir = video.has_parent_path() ? video.parent_path() : fs::path(".");
  std::string found;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const fs::path& p = it->path();
    std::string ext = p.extension().string();
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (p.stem() != video.stem() || ext != ".srt") continue;
    if (!it->is_regular_file(ec)) continue;
    if (!found.empty()) return "";  // DJI_0042.SRT and DJI_0042.srt: not a guess
    found = p.string();
  }
  return found;
}

}  // namespace

RunInputs ResolveInputs(const RunConfig& given, std::vector<std::string>* warnings) {
  RunInputs in;
  in.config = given;
  RunConfig& config = in.config;
  if (const auto m = FindSimulationManifest(config.input, warnings)) {
    in.sim_manifest = (m->dir / "sim.json").string();
    if (config.telemetry.empty() && !m->srt.empty()) config.telemetry = m->srt.string();
    if (config.truth.empty() && !m->csv.empty()) config.truth = m->csv.string();
    if (config.focal_px == 0.0 && config.hfov_deg == 0.0) {
      config.focal_px = m->focal_px;  // exact, whatever the SRT's 35 mm equivalent says
      in.focal_from_sim = true;
    }
  }
  if (config.telemetry.empty()) {
    config.telemetry = TelemetryBeside(config.input);
    in.telemetry_beside = !config.telemetry.empty();
    std::error_code ec;
    if (config.telemetry.empty() && !config.input.empty() &&
        std::filesystem::is_regular_file(config.input, ec) && FindVideoTextTrack(config.input)) {
      config.telemetry = config.input;
      in.telemetry_in_video = true;
    }
  }
  if (!config.truth.empty()) in.truth = ReadReferenceTrack(config.truth);
  return in;
}

namespace {

// The camera triggers of an autopilot log (TelemetryReadResult::camera_triggers) as the
// telemetry of the photos of `folder`, photo k the k-th trigger (frame_index k, time_s from the
// first trigger's, the clock of the photos' own times): nullopt, with a warning saying why and
// what to do, when their number differs from the photos' or, for photos with capture times,
// when the times since the first photo and since the first trigger part by more than
// kMaxTriggerDriftS plus the capture times' resolution (a photo the camera missed, or one taken
// that the log does not know, shifts every pair after it by one interval; an interval below
// that tolerance cannot be told from the capture times' rounding).
std::optional<Telemetry> TelemetryOfTriggers(const std::vector<TelemetrySample>& triggers,
                                             const ImageFolderSource& folder,
                                             const std::string& path,
                                             std::vector<std::string>* warnings) {
  // The camera's shutter lag after the trigger (0.1-0.5 s) is common to all photos and cancels;
  // a camera's quartz clock (tens of parts per million) drifts from the autopilot's by about
  // 0.1 s over an hour.
  constexpr double kMaxTriggerDriftS = 0.5;
  const std::vector<ImageMetadata>& photos = folder.metadata();
  const std::string by_time = fmt::format(
      "the photos are matched to the log's GPS fixes by their capture times instead: give "
      "--telemetry-offset-s, the log's time of the first photo (the first trigger is at "
      "{:.3f} s, {})",
      triggers.front().time_s, triggers.front().origin);
  if (triggers.size() != photos.size()) {
    warnings->push_back(fmt::format(
        "{}: the log's camera logged {} photo(s), the folder holds {}: they cannot be paired one "
        "by one; {}",
        path, triggers.size(), photos.size(), by_time));
    return std::nullopt;
  }
  const bool timed = std::all_of(photos.begin(), photos.end(), [](const ImageMetadata& m) {
    return m.capture_unix_time_s.has_value();
  });
  std::vector<TelemetrySample> samples;
  samples.reserve(triggers.size());
  for (std::size_t k = 0; k < triggers.size(); ++k) {
    TelemetrySample s = triggers[k];
    s.time_s = triggers[k].time_s - triggers.front().time_s;
    s.frame_index = static_cast<int>(k);
    const double photo_s = folder.TimeOf(k) - folder.TimeOf(0);
    // Two capture times cut to their resolution differ from the true interval by less than it.
    const double tolerance_s =
        kMaxTriggerDriftS +
        std::max(photos[k].capture_time_resolution_s, photos.front().capture_time_resolution_s);
    if (timed && !(std::abs(s.time_s - photo_s) <= tolerance_s)) {
      warnings->push_back(fmt::format(
          "{}: photo '{}' was taken {:.3f} s after the first photo, its camera trigger ({}) "
          "{:.3f} s after the first trigger: more than {:.1f} s apart, the photos and the "
          "triggers are not the same sequence (a photo missed or added before it); {}",
          path, photos[k].source, photo_s, s.origin, s.time_s, tolerance_s, by_time));
      return std::nullopt;
    }
    samples.push_back(std::move(s));
  }
  return Telemetry(std::move(samples), path);
}

}  // namespace

RunTelemetry::RunTelemetry(Telemetry telemetry, bool by_frame_index, std::string origin)
    : telemetry_(std::move(telemetry)),
      by_frame_index_(by_frame_index),
      origin_(std::move(origin)) {}

RunTelemetry RunTelemetry::Load(const std::string& path, bool lenient,
                                const ImageFolderSource* folder, std::vector<std::string>* warnings,
                                bool by_time) {
  if (!path.empty()) {
    TelemetryReadOptions to;
    to.lenient = lenient;
    TelemetryReadResult t;
    try {
      t = ReadTelemetryInput(path, to);  // a video: its subtitle track
    } catch (const MalformedRecordError& e) {
      // Only a malformed record (not a missing file, a bad header or a foreign format): say how
      // to go on.
      throw InputError(std::string(e.what()) +
                       " (--lenient-telemetry skips malformed records instead)");
    }
    if (t.skipped_records > 0) {
      warnings->push_back(fmt::format(
          "{}: {} malformed telemetry record(s) skipped (--lenient-telemetry), the first ones:",
          path, t.skipped_records));
    }
    for (auto& w : t.warnings) warnings->push_back(std::move(w));
    if (folder != nullptr && !by_time && !t.camera_triggers.empty()) {
      if (std::optional<Telemetry> paired =
              TelemetryOfTriggers(t.camera_triggers, *folder, path, warnings)) {
        RunTelemetry r(std::move(*paired), true,
                       fmt::format("{} (its camera triggers, one per photo)", path));
        r.from_camera_triggers_ = true;
        return r;
      }
    }
    const bool by_frame_index = t.telemetry.HasFrameIndices();
    return RunTelemetry(std::move(t.telemetry), by_frame_index, path);
  }
  if (folder != nullptr) {
    try {
      TelemetryReadResult t = TelemetryFromImages(folder->metadata());
      for (auto& w : t.warnings) warnings->push_back(std::move(w));
      return RunTelemetry(std::move(t.telemetry), true, "photo EXIF/XMP");
    } catch (const InputError& e) {
      warnings->push_back(std::string("no telemetry from the photos: ") + e.what());
    }
  }
  return RunTelemetry();
}

std::optional<TelemetrySample> RunTelemetry::SampleOf(const Frame& f) const {
  if (telemetry_.empty()) return std::nullopt;
  if (by_frame_index_ && offset_s_ == 0.0) return telemetry_.AtFrame(f.index);
  return telemetry_.Lookup(f.time_s + offset_s_, 0.5);
}

std::string RunTelemetry::OriginOf(int frame_index, double time_s) const {
  if (telemetry_.empty()) return {};
  const std::optional<TelemetrySample> s = by_frame_index_ && offset_s_ == 0.0
                                               ? telemetry_.AtFrame(frame_index)
                                               : telemetry_.Lookup(time_s + offset_s_, 0.5);
  return s ? s->origin : std::string();
}

std::string RunTelemetry::WhyNoFix(const Frame& f) const {
  if (telemetry_.empty()) return "there is no telemetry";
  if (by_frame_index_ && offset_s_ == 0.0) {
    int lo = std::numeric_limits<int>::max(), hi = -1;
    for (const TelemetrySample& s : telemetry_.samples()) {
      if (s.frame_index) {
        lo = std::min(lo, *s.frame_index);
        hi = std::max(hi, *s.frame_index);
      }
    }
    if (f.index < lo) {
      return fmt::format("frame {} is before the first record of {} (frame counter {}{})", f.index,
                         origin_, lo + 1,
                         lo - f.index > kMaxLeadFrames
                             ? ": the second clip of a split recording? give the matching telemetry"
                             : "");
    }
    return fmt::format("frame {} is after the last record of {} (frame counter {})", f.index,
                       origin_, hi + 1);
  }
  const double t = f.time_s + offset_s_;
  return fmt::format(
      "frame {} at {:.3f} s{} is outside the time span of {} ({:.3f} to {:.3f} s): no time "
      "overlap with the video (see --telemetry-offset-s)",
      f.index, t, offset_s_ != 0.0 ? fmt::format(" (offset {:+.3f} s)", offset_s_) : "",
      origin_, telemetry_.start_time_s(), telemetry_.end_time_s());
}

std::optional<TelemetrySample> RunTelemetry::FirstRecordAhead(const Frame& f) const {
  if (telemetry_.empty()) return std::nullopt;
  const std::vector<TelemetrySample>& samples = telemetry_.samples();
  if (by_frame_index_ && offset_s_ == 0.0) {
    // The records in frame order need not be in file order: the first is the smallest index.
    const TelemetrySample* first = nullptr;
    for (const TelemetrySample& s : samples) {
      if (s.frame_index && (first == nullptr || *s.frame_index < *first->frame_index)) first = &s;
    }
    if (first == nullptr || f.index >= *first->frame_index ||
        *first->frame_index - f.index > kMaxLeadFrames) {
      return std::nullopt;
    }
    const TelemetrySample* best = nullptr;  // the first record by frame with a relative altitude
    for (const TelemetrySample& s : samples) {
      if (s.frame_index && s.rel_alt_m && *s.frame_index - f.index <= kMaxLeadFrames &&
          (best == nullptr || *s.frame_index < *best->frame_index)) {
        best = &s;
      }
    }
    return best != nullptr ? std::optional<TelemetrySample>(*best) : std::nullopt;
  }
  const double t = f.time_s + offset_s_;
  const double start = telemetry_.start_time_s();
  if (!(t < start) || start - t > kMaxLeadS) return std::nullopt;
  for (const TelemetrySample& s : samples) {  // in time order (telemetry/telemetry.h)
    if (s.time_s - t > kMaxLeadS) break;
    if (s.rel_alt_m) return s;
  }
  return std::nullopt;
}

std::string RunTelemetry::Describe() const {
  return telemetry_.empty() ? std::string("none")
                            : std::to_string(telemetry_.size()) + " fixes from " + origin_;
}

// ---------------------------------------------------------------------------------------------
// 2. Camera

namespace {

// The lens of the options k1 k2 p1 p2 k3 on the frames of `frame_name` (w x h px, focal_px):
// InputError naming the options when the model turns back inside the frame (camera/lens.h
// FirstFoldedPixel), as a calibration file's lens gets (camera_files/calibration.h).
void CheckLensFlags(const RunConfig& config, double focal_px, int w, int h,
                    const std::string& frame_name) {
  if (config.k1 == 0.0 && config.k2 == 0.0 && config.p1 == 0.0 && config.p2 == 0.0 &&
      config.k3 == 0.0) {
    return;
  }
  CameraIntrinsics k = IntrinsicsFromFocalPx(focal_px, w, h);
  k.distortion = {config.k1, config.k2, config.p1, config.p2, config.k3};
  std::optional<std::array<double, 2>> pixel;
  try {
    pixel = FirstFoldedPixel(k);
  } catch (const InvalidArgument& e) {
    throw InputError(fmt::format("{}: the lens of k1 k2 p1 p2 k3: {}", frame_name, e.what()));
  }
  if (!pixel) return;
  throw InputError(fmt::format(
      "{}: the lens of k1 k2 p1 p2 k3 ({:g} {:g} {:g} {:g} {:g}, focal {:.1f} px) has no ray for "
      "pixel ({:.0f}, {:.0f}) of the {}x{} frames: the model turns back before the frame's edge "
      "and would fold the image there; check the coefficients' signs and that they belong to "
      "this focal length",
      frame_name, config.k1, config.k2, config.p1, config.p2, config.k3, focal_px, (*pixel)[0],
      (*pixel)[1], w, h));
}

}  // namespace

RunCamera ResolveRunCamera(const RunConfig& config, bool focal_from_sim, int w, int h,
                           const ImageMetadata* photo, const std::optional<TelemetrySample>& sample,
                           const std::string& frame_name) {
  CameraOptions camera;
  if (config.focal_px > 0.0) camera.focal_px = config.focal_px;
  if (config.hfov_deg > 0.0) camera.hfov_deg = config.hfov_deg;
  if (config.sensor_aspect > 0.0) camera.sensor_aspect = config.sensor_aspect;
  if (!config.calibration.empty()) {
    camera.calibration = ReadCalibration(config.calibration).intrinsics;
    camera.calibration_source = config.calibration;
    try {
      (void)ScaledTo(*camera.calibration, w, h);
    } catch (const InvalidArgument& e) {
      throw InputError(fmt::format("{}: --calibration '{}': {}", frame_name, config.calibration,
                                   e.what()));
    }
  }
  ResolvedCamera resolved;
  try {
    resolved = ResolveCamera(camera, w, h, photo,
                             sample ? sample->focal_length_35mm_mm : std::nullopt);
  } catch (const InputError&) {
    throw InputError(frame_name +
                     ": the camera focal length is unknown (no EXIF/telemetry "
                     "35 mm focal length): give --focal-px or --hfov-deg");
  }
  if (!camera.calibration) CheckLensFlags(config, resolved.intrinsics.fx_px, w, h, frame_name);
  RunCamera c;
  c.focal_px = resolved.intrinsics.fx_px;
  c.focal_source = focal_from_sim && resolved.source_key == "flag" ? "sim.json" : resolved.source_key;
  c.description = resolved.source;
  if (camera.calibration) c.calibrated = resolved.intrinsics;
  return c;
}

std::unique_ptr<FrameUndistorter> MakeUndistorter(const RunConfig& config, int w, int h,
                                                  double focal_px) {
  if (config.k1 == 0.0 && config.k2 == 0.0 && config.p1 == 0.0 && config.p2 == 0.0 &&
      config.k3 == 0.0) {
    return nullptr;
  }
  return std::make_unique<FrameUndistorter>(w, h, focal_px, config.k1, config.k2, config.p1,
                                            config.p2, config.k3);
}

std::optional<CameraIntrinsics> RunLens(const RunConfig& config, const RunCamera& camera, int w,
                                        int h, double focal_px) {
  if (camera.calibrated) {
    const CameraIntrinsics k = ScaledTo(*camera.calibrated, w, h);
    const CameraIntrinsics ideal = IntrinsicsFromFocalPx(k.fx_px, w, h);
    if (!k.HasDistortion() && k.fy_px == ideal.fy_px && k.cx_px == ideal.cx_px &&
        k.cy_px == ideal.cy_px) {
      return std::nullopt;
    }
    return k;
  }
  if (config.k1 == 0.0 && config.k2 == 0.0 && config.p1 == 0.0 && config.p2 == 0.0 &&
      config.k3 == 0.0) {
    return std::nullopt;
  }
  CameraIntrinsics k = IntrinsicsFromFocalPx(focal_px, w, h);
  k.distortion = {config.k1, config.k2, config.p1, config.p2, config.k3};
  return k;
}

UndistortMode ChooseUndistortion(UndistortMode mode, const CameraIntrinsics& lens,
                                 double* scale_change) {
  *scale_change = MaxLensScaleChange(lens);
  if (mode != UndistortMode::kAuto) return mode;
  return *scale_change <= kPointsMaxScaleChange ? UndistortMode::kPoints : UndistortMode::kFrames;
}

std::unique_ptr<FrameUndistorter> MakeUndistorter(const CameraIntrinsics& calibrated, int w,
                                                  int h) {
  const CameraIntrinsics k = ScaledTo(calibrated, w, h);
  const CameraIntrinsics ideal = IntrinsicsFromFocalPx(k.fx_px, w, h);
  if (!k.HasDistortion() && k.fy_px == ideal.fy_px && k.cx_px == ideal.cx_px &&
      k.cy_px == ideal.cy_px) {
    return nullptr;
  }
  return std::make_unique<FrameUndistorter>(k);
}

// ---------------------------------------------------------------------------------------------
// 3. Height above ground

double HeightProvider::HeightOf(const std::string& frame_name,
                                const std::optional<TelemetrySample>& sample,
                                std::vector<std::string>* warnings, double capture_s) {
  if (flag_m_ > 0.0) {
    last_source_ = FrameHeightSource::kAltitudeFlag;
    return flag_m_;
  }
  if (link_ != nullptr) {
    std::optional<mavlink::AutopilotHeight> h = link_->HeightNear(capture_s, match_s_);
    // The first frame may have waited for the link's first sample (mavlink_wait_s).
    if (!h && !last_m_) h = link_->HeightNear(mavlink::MonotonicNowS(), match_s_);
    if (h && h->height_m > 0.0) {
      last_m_ = h->height_m;
      last_source_ = h->source == mavlink::HeightSourceKind::kDistanceSensor
                         ? FrameHeightSource::kMavlinkDistanceSensor
                         : FrameHeightSource::kMavlinkRelativeAlt;
      return *last_m_;
    }
  }
  if (sample && sample->rel_alt_m && *sample->rel_alt_m + takeoff_height_agl_m_ > 0.0) {
    last_m_ = *sample->rel_alt_m + takeoff_height_agl_m_;
    last_source_ = takeoff_height_agl_m_ == 0.0 ? FrameHeightSource::kTelemetry
                                                : FrameHeightSource::kTelemetryRelAltTakeoff;
    return *last_m_;
  }
  const bool amsl_only = sample && !sample->rel_alt_m && sample->abs_alt_m;
  if (amsl_only && std::isfinite(ground_elevation_m_)) {
    const double h = *sample->abs_alt_m - ground_elevation_m_;
    if (!(h > 0.0)) {
      throw InputError(fmt::format(
          "{}: the altitude above sea level {:.1f} m minus ground_elevation_m {:.1f} m is {:.1f} "
          "m, not above the ground: check --ground-elevation-m",
          frame_name, *sample->abs_alt_m, ground_elevation_m_, h));
    }
    last_m_ = h;
    last_source_ = FrameHeightSource::kTelemetryAbsAltGround;
    return *last_m_;
  }
  if (amsl_only && !last_m_) {
    // Only an altitude above sea level (a photo's GPSAltitude, an SRT's abs_alt): without the
    // ground's it says nothing about the height above ground.
    throw InputError(fmt::format(
        "{}: no height above ground: {} gives only an altitude above sea level ({:.1f} m) and "
        "no relative altitude: give --ground-elevation-m (the ground's altitude above sea "
        "level) or --altitude",
        frame_name, telemetry_name_.empty() ? "the telemetry" : telemetry_name_,
        *sample->abs_alt_m));
  }
  // Frames before the first record (no height known yet, or only the first record's).
  const bool lead_in =
      last_source_ == FrameHeightSource::kNone || last_source_ == FrameHeightSource::kFirstRecord;
  if (!sample && lead_in && first_record_ahead_ && first_record_ahead_->rel_alt_m &&
      *first_record_ahead_->rel_alt_m + takeoff_height_agl_m_ > 0.0) {
    last_m_ = *first_record_ahead_->rel_alt_m + takeoff_height_agl_m_;
    if (!warned_ahead_) {
      warnings->push_back(fmt::format(
          "{}: no telemetry record ({}); its height is that of the first record ahead, {:.1f} m "
          "({}), until a frame has its own (give --altitude to set it)",
          frame_name, no_fix_reason_.empty() ? "the frame has no telemetry fix" : no_fix_reason_,
          *last_m_,
          first_record_ahead_->origin.empty()
              ? fmt::format("at {:.3f} s", first_record_ahead_->time_s)
              : first_record_ahead_->origin));
      warned_ahead_ = true;
    }
    last_source_ = FrameHeightSource::kFirstRecord;
    return *last_m_;
  }
  if (last_m_) {
    if (!warned_) {
      warnings->push_back(frame_name + ": no " +
                          (link_ != nullptr ? "height from the autopilot or " : "") +
                          "relative altitude, using the last known (" +
                          fmt::format("{:.1f}", *last_m_) + " m)");
      warned_ = true;
    }
    last_source_ = FrameHeightSource::kLastKnown;
    return *last_m_;
  }
  if (link_ != nullptr) {
    throw InputError(frame_name +
                     ": no height above ground (nothing from the autopilot on the MAVLink link: "
                     "no downward DISTANCE_SENSOR or GLOBAL_POSITION_INT, and no telemetry "
                     "relative altitude): give --altitude");
  }
  std::string why;
  if (!sample) {
    why = no_fix_reason_.empty() ? "the frame has no telemetry fix" : no_fix_reason_;
  } else if (!sample->rel_alt_m) {
    why = "the telemetry has no relative altitude";
  } else {
    why = fmt::format(
        "the telemetry's relative altitude is {:.1f} m, not above the take-off point "
        "(landed, or a take-off point above the area flown? see --takeoff-height-agl-m)",
        *sample->rel_alt_m);
  }
  throw InputError(frame_name + ": no height above ground (" + why + "): give --altitude");
}

FrameAttitude CameraAttitudeOf(const RunConfig& config,
                               const std::optional<TelemetrySample>& sample,
                               const std::optional<mavlink::AutopilotAttitude>& link,
                               const std::optional<CameraAttitude>& estimated) {
  FrameAttitude out;
  // An aircraft's roll and pitch (radians) to its fixed camera's.
  const auto fixed_camera = [&](double roll_rad, double pitch_rad) {
    const Eigen::Matrix3d level_from_camera =
        LevelFromCameraFrd({roll_rad / kDegToRad, pitch_rad / kDegToRad}) *
        LevelFromCameraFrd({0.0, config.camera_mount_pitch_deg});
    return AttitudeOfRotation(level_from_camera);
  };
  if (sample && (sample->gimbal_pitch_deg || sample->gimbal_roll_deg)) {
    out.reported = CameraAttitude{sample->gimbal_roll_deg.value_or(0.0),
                                  sample->gimbal_pitch_deg.value_or(-90.0) + 90.0};
    out.source = AttitudeSource::kGimbal;
  } else if (link) {
    out.reported = fixed_camera(link->roll_rad, link->pitch_rad);
    out.source = AttitudeSource::kMavlink;
  } else if (sample && (sample->pitch_deg || sample->roll_deg)) {
    out.reported = fixed_camera(sample->roll_deg.value_or(0.0) * kDegToRad,
                                sample->pitch_deg.value_or(0.0) * kDegToRad);
    out.source = AttitudeSource::kFlight;
  } else if (config.camera_mount_pitch_deg != 0.0) {
    out.reported = fixed_camera(0.0, 0.0);  // the aircraft taken as level
    out.source = AttitudeSource::kMount;
  } else if (estimated) {
    out.reported = estimated;
    out.source = AttitudeSource::kEstimated;
  }
  if (out.reported && config.attitude == AttitudeMode::kAuto &&
      TiltFromNadirDeg(*out.reported) >= config.attitude_min_deg) {
    out.camera = out.reported;
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// 4. Outputs

namespace {

// The odometry's part of frames.csv's status: "ok", "bridged:too-few-inliers", ...
std::string StepStatusOf(const FrameResult& r) {
  std::string status = ToString(r.status);
  if (r.failure != StepFailure::kNone) status += std::string(":") + ToString(r.failure);
  return status;
}

// The pose and the odometry's counts of `r` into `p` (not its status, times or frame).
void SetPoseAndCounts(PendingFrame& p, const FrameResult& r) {
  p.local_m = r.position_m;
  p.heading_rad = r.heading_rad;
  p.quality = PoseQuality(r);
  FrameRecord& rec = p.record;
  rec.n_surf = r.n_surf;
  rec.n_matched = r.n_matched;
  rec.n_inliers = r.n_inliers;
  rec.cluster = r.cluster;
}

}  // namespace

PendingFrame PendingFrameOf(const Frame& frame, const FrameResult& r,
                            const std::optional<GeoPoint>& gps, double height_m) {
  PendingFrame p;
  SetPoseAndCounts(p, r);
  p.gps = gps;
  p.height_m = height_m;
  FrameRecord& rec = p.record;
  rec.frame = frame.index;
  rec.time_s = frame.time_s;
  rec.detect_ms = r.detect_ms;
  rec.describe_ms = r.describe_ms;
  rec.correspond_ms = r.correspond_ms;
  rec.estimate_ms = r.estimate_ms;
  rec.total_ms = r.total_ms;
  rec.status = StepStatusOf(r);
  if (!frame.flags.empty()) rec.status += "+" + frame.flags;
  return p;
}

void ReplacePose(PendingFrame& p, const FrameResult& r) {
  SetPoseAndCounts(p, r);
  FrameRecord& rec = p.record;
  const std::size_t plus = rec.status.find('+');
  rec.status = StepStatusOf(r) + (plus == std::string::npos ? "" : rec.status.substr(plus));
}

namespace {

double Degrees(double rad) { return rad * kRadToDeg; }

// The geographic fields of a pose-stream line.
void AddGeoFields(const PendingFrame& p, const GeoReferencer& georef, nlohmann::ordered_json& j) {
  const GeoPoint g = georef.Wgs84FromLocal(p.local_m);
  const Eigen::Vector2d enu = georef.EnuFromLocal(p.local_m);
  j["lat_deg"] = g.lat_deg;
  j["lon_deg"] = g.lon_deg;
  j["east_m"] = enu.x();
  j["north_m"] = enu.y();
  j["yaw_enu_deg"] = Degrees(std::remainder(p.heading_rad + georef.rotation_rad(), 2.0 * M_PI));
}

// Writes and flushes one line of a pose stream. A stream that cannot take it (disk full, an I/O
// error) stops the run like any output file that cannot be written: its consumer (an autopilot
// bridge, a logger) must not go on without poses while the run reports success. `errno` is the
// failed write's (stdio and the file buffer leave it set). A reader that went away (EPIPE)
// raised SIGPIPE for the same write: when a handler takes it (`aerovo run`'s StopSignals: the
// run stops as for SIGINT, exit 141) the handler decides, and the stream's state is cleared so
// that a later write fails with EPIPE again rather than silently; only when SIGPIPE is ignored
// does the broken pipe stop the run here.
void WritePoseLine(std::ostream& os, const std::string& line, const std::string& name) {
  errno = 0;
  os << line << std::flush;
  if (os) return;
  const int err = errno;
  if (err == EPIPE) {
    struct sigaction current {};
    if (::sigaction(SIGPIPE, nullptr, &current) == 0 && current.sa_handler != SIG_IGN) {
      os.clear();
      return;
    }
  }
  throw InputError(fmt::format("cannot write the pose stream to {}: {}", name,
                               err != 0 ? std::strerror(err) : "write failed"));
}

// A finite number, or null (JSON has no NaN).
nlohmann::ordered_json NumberOrNull(double v) {
  return std::isfinite(v) ? nlohmann::ordered_json(v) : nlohmann::ordered_json();
}

}  // namespace

std::string PoseJsonLine(const PendingFrame& p, const GeoReferencer& georef) {
  const FrameRecord& r = p.record;
  nlohmann::ordered_json j{{"type", "pose"},
                           {"index", r.frame},
                           {"time_s", r.time_s},
                           {"x_m", p.local_m.x()},
                           {"y_m", p.local_m.y()},
                           {"z_m", p.height_m},
                           {"heading_deg", Degrees(p.heading_rad)},
                           {"status", r.status},
                           {"quality", p.quality},
                           {"latency_ms", NumberOrNull(r.latency_ms)}};
  if (std::isfinite(p.sigma_xy_m)) {
    j["sigma_xy_m"] = p.sigma_xy_m;
    j["sigma_heading_deg"] = NumberOrNull(p.sigma_heading_deg);
  }
  if (georef.ready()) AddGeoFields(p, georef, j);
  return j.dump() + "\n";
}

std::string GeoJsonLine(const PendingFrame& p, const GeoReferencer& georef) {
  nlohmann::ordered_json j{{"type", "geo"}, {"index", p.record.frame}, {"time_s", p.record.time_s}};
  AddGeoFields(p, georef, j);
  return j.dump() + "\n";
}

RunOutputs::RunOutputs(const std::filesystem::path& out_dir, const RunConfig& config,
                       const RunCamera& camera, const std::string& height_source, int w, int h,
                       double first_time_s, const std::optional<TelemetrySample>& first_sample,
                       const RunCallbacks& callbacks, bool wait_for_heading)
    : callbacks_(callbacks), wait_for_heading_(wait_for_heading) {
  TrackWriterOptions wo;
  // No ENU origin yet: it is the run's (GeoReferencer::enu(), the first accepted fix), set at
  // the first frame written (Emit), which waits for the heading when there is telemetry.
  if (first_sample && first_sample->unix_time_s)
    wo.time_origin_unix_s = *first_sample->unix_time_s - first_time_s;
  wo.run_name = FlightNameOf(config.input);  // names the tracks in KML/GPX/GeoJSON
  writers_ = std::make_unique<TrackWriterSet>(out_dir, wo);
  nlohmann::json effective = ToJson(config);
  effective["resolved"] = {{"focal_px", camera.focal_px},
                           {"focal_source", camera.focal_source},
                           {"height_source", height_source},
                           {"frame_width_px", w},
                           {"frame_height_px", h}};
  WriteJsonFileAtomic(out_dir / RunFileNames::kConfigJson, effective);
  transforms_csv_.emplace(out_dir / RunFileNames::kTransformsCsv);
  jsonl_name_ =
      config.poses_jsonl == "-" ? "stdout (--poses-jsonl -)" : "'" + config.poses_jsonl + "'";
  if (config.poses_jsonl == "-") {
    jsonl_ = &std::cout;
  } else if (!config.poses_jsonl.empty()) {
    // The pose stream never overwrites one of the run's own inputs (a file given twice).
    std::vector<std::pair<const char*, std::string>> inputs = {{"input", config.input},
                                                               {"telemetry", config.telemetry},
                                                               {"calibration", config.calibration}};
    for (const std::string& m : config.map) inputs.emplace_back("map", m);
    for (const auto& [what, path] : inputs) {
      std::error_code ec;
      if (!path.empty() && std::filesystem::equivalent(config.poses_jsonl, path, ec)) {
        throw InputError(
            fmt::format("the pose stream '{}' is the run's {} '{}': it would be "
                        "overwritten; give --poses-jsonl another file",
                        config.poses_jsonl, what, path));
      }
    }
    auto file = std::make_unique<std::ofstream>(config.poses_jsonl, std::ios::trunc);
    if (!*file) {
      throw InputError("cannot write the pose stream '" + config.poses_jsonl +
                       "': " + std::strerror(errno));
    }
    jsonl_file_ = std::move(file);
    jsonl_ = jsonl_file_.get();
  }
}

void RunOutputs::AppendTransform(int frame_index, const Eigen::Matrix3d& world_from_frame) {
  if (hold_for_replay_) {
    held_transforms_.emplace_back(frame_index, world_from_frame);
    return;
  }
  if (!have_first_) {
    first_px_from_world_ = world_from_frame.inverse();
    have_first_ = true;
  }
  const Eigen::Matrix3d first_px_from_frame = first_px_from_world_ * world_from_frame;
  transforms_csv_->Append(frame_index, first_px_from_frame);
}

// Writes a frame: geo-referenced when possible, else in the local VO frame.
void RunOutputs::Emit(PendingFrame& p, const GeoReferencer& georef) {
  if (!p.local_m.allFinite()) {
    throw InputError(fmt::format("frame {}: the visual odometry's position is not finite",
                                 p.record.frame));
  }
  if (georef.ready()) {
    const Eigen::Vector2d enu = georef.EnuFromLocal(p.local_m);
    if (!enu.allFinite() || enu.norm() > 1e7) {
      throw InputError(fmt::format(
          "frame {}: the geo-referenced position ({}, {}) m is not a place on Earth (height "
          "or focal length absurd?)",
          p.record.frame, enu.x(), enu.y()));
    }
    p.record.x_m = enu.x();
    p.record.y_m = enu.y();
    p.record.geo = georef.TrackWgs84FromLocal(p.local_m);
    p.record.yaw_rad = std::remainder(p.heading_rad + georef.rotation_rad(), 2.0 * M_PI);
  } else {
    p.record.x_m = p.local_m.x();
    p.record.y_m = p.local_m.y();
    p.record.yaw_rad = p.heading_rad;
  }
  // gps.tum's frame: the run's ENU frame, the same as x_m/y_m, vo.tum and the comparisons.
  if (georef.has_enu() && !writers_->has_enu_origin()) writers_->SetEnuOrigin(georef.enu().origin());
  if (jsonl_ != nullptr && !p.sent_geo && georef.ready()) {
    WritePoseLine(*jsonl_, GeoJsonLine(p, georef), jsonl_name_);
    p.sent_geo = true;
  }
  writers_->Append(p.record, p.gps);
  if (callbacks_.frame) callbacks_.frame(p.record);
  if (callbacks_.poses != nullptr) {
    const FrameRecord& q = p.record;
    WritePoseLine(*callbacks_.poses,
                  fmt::format("{} {:.6f} {:.4f} {:.4f} {} {} {}\n", q.frame, q.time_s, q.x_m, q.y_m,
                              q.geo ? fmt::format("{:.9f}", q.geo->lat_deg) : "-",
                              q.geo ? fmt::format("{:.9f}", q.geo->lon_deg) : "-", q.status),
                  "stdout (--print-poses)");
  }
}

void RunOutputs::Flush(const GeoReferencer& georef, bool final) {
  // With GPS in the telemetry, wait for the heading (bounded: GeoRefOptions::min_segment_m);
  // wait for the lens switch's replay (bounded: lens_switch.h).
  if (!final && ((!georef.ready() && wait_for_heading_) || hold_for_replay_)) return;
  while (!pending_.empty()) {
    Emit(pending_.front(), georef);
    pending_.pop_front();
  }
}

void RunOutputs::Reflag(int frame_index, const std::string& gps_flag) {
  for (PendingFrame& p : pending_) {
    if (p.record.frame == frame_index) p.record.gps_flag = gps_flag;
  }
}

void RunOutputs::ReleaseHeld(const std::vector<ReplayedPose>& replayed) {
  if (!hold_for_replay_) return;
  hold_for_replay_ = false;
  // Both the queue and the replayed poses are in frame order.
  auto next = replayed.begin();
  const auto replayed_pose = [&](int frame) -> const ReplayedPose* {
    while (next != replayed.end() && next->frame < frame) ++next;
    return next != replayed.end() && next->frame == frame ? &*next : nullptr;
  };
  for (PendingFrame& p : pending_) {
    if (const ReplayedPose* r = replayed_pose(p.record.frame)) ReplacePose(p, r->result);
  }
  next = replayed.begin();
  for (const auto& [frame, world_from_frame] : held_transforms_) {
    const ReplayedPose* r = replayed_pose(frame);
    AppendTransform(frame, r ? r->world_from_full : world_from_frame);
  }
  held_transforms_.clear();
  held_transforms_.shrink_to_fit();
}

void RunOutputs::Add(PendingFrame frame, const GeoReferencer& georef) {
  SendPose(frame, georef);
  Enqueue(std::move(frame), georef);
}

void RunOutputs::SendPose(PendingFrame& frame, const GeoReferencer& georef) {
  if (jsonl_ == nullptr) return;
  // Frames held back for the heading are still sent at once, in the local frame.
  WritePoseLine(*jsonl_, PoseJsonLine(frame, georef), jsonl_name_);
  frame.sent_geo = georef.ready();
}

void RunOutputs::Enqueue(PendingFrame frame, const GeoReferencer& georef) {
  pending_.push_back(std::move(frame));
  Flush(georef, false);
}

int RunOutputs::frames_written() const { return writers_->csv_rows(); }

void RunOutputs::Finish(GeoReferencer& georef) {
  ReleaseHeld({});  // the lens switch never released them (a failure): the live poses
  if (!georef.ready() && georef.has_enu()) georef.FixWithAvailable();
  Flush(georef, true);
  writers_->Close();
  if (jsonl_ != nullptr) jsonl_->flush();
}

// ---------------------------------------------------------------------------------------------
// 5. What the per-frame loop accumulates (pipeline/frame_loop.h)

void RunTotals::Add(int frame_index, double time_s, const FrameResult& r,
                    const std::optional<GeoPoint>& gps, bool withheld) {
  if (r.status == FrameStatus::kOk || r.status == FrameStatus::kReacquired) ++measured_steps;
  if (keep_track) {
    local_track.push_back({time_s, r.position_m.x(), r.position_m.y()});
    track_frames.push_back(frame_index);
  }
  if (gps) ++frames_with_gps;
  if (gps) {
    gps_track.push_back({time_s, 0.0, 0.0});  // x/y: CompareWithGps, in the final ENU frame
    gps_geo.push_back(*gps);
    local_at_gps.push_back({time_s, r.position_m.x(), r.position_m.y()});
    gps_frames.push_back(frame_index);
    gps_rejected.push_back(0);
    gps_withheld.push_back(withheld ? 1 : 0);
  }
  if (frames == 0) first_time_s = time_s;
  last_time_s = time_s;
  if (frames > 0) path_length_m += (r.position_m - last_local_m).norm();
  last_local_m = r.position_m;
  sum_ms.detect_ms += r.detect_ms;
  sum_ms.describe_ms += r.describe_ms;
  sum_ms.correspond_ms += r.correspond_ms;
  sum_ms.estimate_ms += r.estimate_ms;
  sum_ms.total_ms += r.total_ms;
  ++frames;
}

void RunTotals::ReplacePoses(const std::vector<ReplayedPose>& replayed) {
  const auto replace = [&replayed](const std::vector<int>& frames,
                                   std::vector<TrajectoryPoint2D>& points) {
    auto next = replayed.begin();  // both in frame order
    for (std::size_t i = 0; i < frames.size() && next != replayed.end(); ++i) {
      while (next != replayed.end() && next->frame < frames[i]) ++next;
      if (next == replayed.end() || next->frame != frames[i]) continue;
      points[i].x = next->result.position_m.x();
      points[i].y = next->result.position_m.y();
    }
  };
  replace(track_frames, local_track);
  replace(gps_frames, local_at_gps);
  path_length_m = 0.0;
  for (std::size_t i = 1; i < local_track.size(); ++i) {
    path_length_m += std::hypot(local_track[i].x - local_track[i - 1].x,
                                local_track[i].y - local_track[i - 1].y);
  }
  if (!local_track.empty()) last_local_m = {local_track.back().x, local_track.back().y};
}

void RunTotals::SetRejected(int frame_index, bool rejected) {
  // Frames arrive in order: search from the end (a switch concerns the latest fixes).
  for (std::size_t i = gps_frames.size(); i-- > 0;) {
    if (gps_frames[i] == frame_index) {
      gps_rejected[i] = rejected ? 1 : 0;
      return;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// 6. Summary

namespace {

// Compares the processed frames' track (ENU when geo-referenced, else local) with the ground
// truth, paired by AssociateWithTruth in the run's ENU frame (origin: first GPS fix; without GPS
// an ENU frame at the truth's first point, and then only the aligned figures mean anything).
void CompareWithTruth(const ReferenceTrack& truth, const std::vector<TrajectoryPoint2D>& track,
                      const std::vector<int>& track_frames, const GeoReferencer& georef,
                      RunSummary* summary) {
  std::vector<TrajectoryPoint2D> estimate = track;
  if (georef.ready()) {
    for (TrajectoryPoint2D& q : estimate) {
      const Eigen::Vector2d e = georef.EnuFromLocal({q.x, q.y});
      q.x = e.x();
      q.y = e.y();
    }
  } else {
    summary->warnings.push_back(
        "the track is not geo-referenced: compare it with the truth after alignment only");
  }
  try {
    const AssociatedTrajectories pairs =
        AssociateWithTruth(estimate, track_frames, truth,
                           georef.has_enu() ? std::optional<LocalEnu>(georef.enu()) : std::nullopt);
    summary->frames_with_truth = static_cast<int>(pairs.estimate.size());
    if (pairs.estimate.size() < 3) {
      summary->warnings.push_back(
          fmt::format("no comparison with the truth: only {} frames fall inside its time span",
                      pairs.estimate.size()));
      return;
    }
    summary->truth_evaluation = CompareTrajectories(pairs.estimate, pairs.reference);
  } catch (const InvalidArgument& e) {
    summary->warnings.push_back(std::string("no comparison with the truth: ") + e.what());
  }
}

// The SE(2) / Sim(2) comparison with GPS (ENU when geo-referenced) of at least 3 fixes, the
// rejected ones left out; a warning saying why when there is none.
void CompareWithGps(const GeoReferencer& georef, RunTotals& totals, RunSummary* summary) {
  // The run's ENU frame (origin: the first accepted fix, georef.h); the fixes were kept as WGS84
  // because a bad first fix may have been superseded (and the frame moved) after they came.
  std::optional<LocalEnu> enu;
  if (georef.has_enu()) enu.emplace(georef.enu());
  std::vector<TrajectoryPoint2D> local, gps;
  for (std::size_t i = 0; i < totals.gps_track.size(); ++i) {
    if (totals.gps_rejected[i]) continue;
    if (!enu) enu.emplace(totals.gps_geo[i]);
    const Eigen::Vector3d e = enu->Forward(totals.gps_geo[i]);
    totals.gps_track[i].x = e.x();
    totals.gps_track[i].y = e.y();
    local.push_back(totals.local_at_gps[i]);
    gps.push_back(totals.gps_track[i]);
  }
  const auto none = [&](std::string why) {
    summary->gps_comparison_note = why;
    summary->warnings.push_back("no comparison with GPS: " + why);
  };
  if (totals.frames_with_gps == 0) {
    summary->gps_comparison_note = "no frame has a GPS fix";
    return;
  }
  if (gps.size() < 3) {
    none(fmt::format("{} of {} frames have a fix{}: fewer than 3 usable",
                     totals.frames_with_gps, totals.frames,
                     gps.size() < totals.gps_track.size()
                         ? fmt::format(", {} rejected as implausible", totals.gps_track.size() - gps.size())
                         : std::string()));
    return;
  }
  if (georef.ready()) {
    for (TrajectoryPoint2D& q : local) {
      const Eigen::Vector2d e = georef.EnuFromLocal({q.x, q.y});
      q.x = e.x();
      q.y = e.y();
    }
  }
  try {
    summary->evaluation = CompareTrajectories(local, gps);
  } catch (const InvalidArgument& e) {
    if (totals.measured_steps == 0) {
      none(fmt::format("{} frames have a fix, but no step between frames was measured (every "
                       "frame after the first is bridged: {})",
                       gps.size(), e.what()));
    } else {
      none(e.what());
    }
    return;
  }
  // A track mirrored against GPS: no alignment fixes it, and the figures alone do not say why.
  if (const std::optional<MirrorCheck> m = CheckMirrored(local, gps); m && m->mirrored) {
    summary->warnings.push_back(fmt::format(
        "the visual track matches the GPS track only as its mirror image (Sim(2) ATE {:.1f} m; "
        "{:.1f} m mirrored, over a track {:.0f} m across): latitude and longitude swapped in "
        "the telemetry, or a mirrored camera image?",
        m->rmse_m, m->mirrored_rmse_m, 2.0 * m->spread_m));
  }
}

// GPS denial (RunConfig::gps_denied_after_s): the geo-referenced track against the withheld
// fixes from the first denied frame on, unaligned (eval/denied_error.h); nullopt with a note
// when the track is not geo-referenced or no fix was withheld.
std::optional<DeniedError> CompareWithWithheld(const GeoReferencer& georef,
                                               const RunTotals& totals, std::string* note) {
  if (!georef.ready()) {
    *note = "the track is not geo-referenced (GPS denied before the heading was known)";
    return std::nullopt;
  }
  std::vector<TrajectoryPoint2D> estimate, withheld;
  for (std::size_t i = 0; i < totals.gps_geo.size(); ++i) {
    if (!totals.gps_withheld[i]) continue;
    const Eigen::Vector3d g = georef.enu().Forward(totals.gps_geo[i]);
    const TrajectoryPoint2D& l = totals.local_at_gps[i];
    const Eigen::Vector2d e = georef.EnuFromLocal({l.x, l.y});
    estimate.push_back({l.t, e.x(), e.y()});
    withheld.push_back({l.t, g.x(), g.y()});
  }
  std::optional<DeniedError> d = CompareSinceDenial(estimate, withheld, *totals.denied_at_s);
  if (!d) *note = "no frame after the denial has a fix in the telemetry";
  return d;
}

// summary->gps_denied when the run was asked to deny GPS (summary->gps_denied->after_s set).
void SummarizeDenial(const GeoReferencer& georef, const RunTotals& totals, RunSummary* summary) {
  if (!summary->gps_denied) return;
  RunSummary::GpsDenied& d = *summary->gps_denied;
  if (!totals.denied_at_s) {
    d.note = fmt::format("the flight ended before the GPS denial ({} s after the first frame)",
                         d.after_s);
    summary->warnings.push_back("no GPS denial: " + d.note);
    return;
  }
  d.from_frame = totals.denied_from_frame;
  d.from_time_s = *totals.denied_at_s;
  d.fixes_withheld = static_cast<int>(
      std::count(totals.gps_withheld.begin(), totals.gps_withheld.end(), char{1}));
  d.error = CompareWithWithheld(georef, totals, &d.note);
}

// The warnings about single frames: one per flag of the frames the source flagged (count,
// first frame, meaning), the GPS fixes rejected (the first 20 said, 100 listed).
void AddFrameWarnings(const LoopEnd& end, RunSummary* summary) {
  RunSummary& s = *summary;
  for (const auto& [flag, n] : s.frames_flagged) {
    const auto first = end.first_flagged.find(flag);
    const std::string first_name = first != end.first_flagged.end() ? first->second : "?";
    std::string what;
    if (flag == kFrameFlagDuplicate) {
      what = "pixels identical to the frame before (a repeated or stale frame): their steps read "
             "as no motion";
    } else if (flag == kFrameFlagTruncated) {
      what = "the photo file is cut short and was decoded with the missing part filled in";
    } else {
      what = "flagged by the frame source";
    }
    s.warnings.push_back(fmt::format("{} of {} frames flagged '{}' (first: {}): {}; see their "
                                     "status in frames.csv",
                                     n, s.frames_processed, flag, first_name, what));
  }
  s.gps_rejected = static_cast<int>(end.rejected_fixes.size());
  for (const RejectedFix& r : end.rejected_fixes) {
    if (s.gps_rejected_fixes.size() < 100) {
      s.gps_rejected_fixes.push_back({r.frame, r.time_s, r.kind, r.message});
    }
    if (s.gps_rejected_fixes.size() <= 20) s.warnings.push_back(r.message);
  }
  if (s.gps_rejected > 20) {
    s.warnings.push_back(fmt::format("... {} GPS fixes rejected in all (summary.json lists the "
                                     "first 100, frames.csv flags every one: gps_flag)",
                                     s.gps_rejected));
  }
}

}  // namespace

void Summarize(const std::vector<std::string>& source_warnings, bool has_telemetry,
               const LoopEnd& end, const OdometryStats* vo_stats, const GeoReferencer& georef,
               RunTotals totals, const ReferenceTrack* truth, double wall_s, RunSummary* summary) {
  RunSummary& s = *summary;
  for (const std::string& w : source_warnings) s.warnings.push_back(w);
  if (has_telemetry && end.frames_without_fix > 0) {
    s.warnings.push_back(fmt::format(
        "{} of {} frames have no telemetry fix (the telemetry does not cover them, or its "
        "records say no GPS fix there); their gps_* "
        "cells are empty and they are not in the comparison with GPS",
        end.frames_without_fix, s.frames_processed));
  }
  AddFrameWarnings(end, summary);
  s.interrupted = end.stopped;
  if (vo_stats != nullptr) {
    s.frames_ok = vo_stats->ok;
    s.frames_reacquired = vo_stats->reacquired;
    s.frames_bridged = vo_stats->bridged;
    if (vo_stats->frames > 1 && totals.measured_steps == 0) {
      // Only the first frame "succeeded": nothing was measured, the track is a placeholder.
      s.warnings.push_back(
          "no frame could be matched to another (dark, blank or textureless frames?): the "
          "trajectory was not measured, every position is bridged");
    }
  }
  s.frames_with_gps = totals.frames_with_gps;
  s.vo_path_length_m = totals.path_length_m;
  s.heading_source = georef.heading_source_used();
  if (georef.has_enu()) {
    s.enu_origin = georef.enu().origin();
    // A map's position has no altitude (summary.json enu_origin.alt_m null).
    if (!georef.altitude_known()) s.enu_origin->alt_m = std::numeric_limits<double>::quiet_NaN();
  }
  const double n = std::max(1, s.frames_processed);
  const StageTimes& sum = totals.sum_ms;
  s.mean = {sum.detect_ms / n, sum.describe_ms / n, sum.correspond_ms / n, sum.estimate_ms / n,
            sum.total_ms / n};
  s.wall_s = wall_s;
  s.fps = s.frames_processed / std::max(1e-9, s.wall_s);
  if (!totals.latency_ms.empty()) {
    std::vector<float>& l = totals.latency_ms;
    const auto at = [&l](double q) {  // nearest-rank percentile
      const std::size_t k = static_cast<std::size_t>(
          std::clamp<double>(std::ceil(q * l.size()) - 1.0, 0.0, l.size() - 1.0));
      std::nth_element(l.begin(), l.begin() + k, l.end());
      return static_cast<double>(l[k]);
    };
    s.latency.frames = static_cast<int>(l.size());
    s.latency.median_ms = at(0.5);
    s.latency.p95_ms = at(0.95);
    s.latency.max_ms = *std::max_element(l.begin(), l.end());
  }
  if (s.frames_dropped > 0) {
    s.warnings.push_back(fmt::format(
        "{} frames of the live source were dropped: they came faster than they were processed "
        "(the newest frame is always taken; frames_dropped in summary.json)",
        s.frames_dropped));
  }
  CompareWithGps(georef, totals, summary);
  SummarizeDenial(georef, totals, summary);
  if (truth != nullptr && !totals.local_track.empty()) {
    CompareWithTruth(*truth, totals.local_track, totals.track_frames, georef, summary);
  }
  s.error = end.failure ? end.failure->Text() : std::string();
}

namespace {

// `totals` with every local position replaced by the optimised one of its frame (source index;
// `flight.frames` is increasing).
RunTotals OptimizedTotals(const FlightRecording& flight, const OptimizedFlight& opt,
                          RunTotals totals) {
  const auto at = [&](int frame, TrajectoryPoint2D* p) {
    const auto it = std::lower_bound(flight.frames.begin(), flight.frames.end(), frame);
    if (it == flight.frames.end() || *it != frame) return;
    const Eigen::Vector2d& q =
        opt.local_from_frame[static_cast<std::size_t>(it - flight.frames.begin())].translation_m;
    p->x = q.x();
    p->y = q.y();
  };
  for (std::size_t k = 0; k < totals.local_track.size(); ++k) {
    at(totals.track_frames[k], &totals.local_track[k]);
  }
  for (std::size_t k = 0; k < totals.local_at_gps.size(); ++k) {
    at(totals.gps_frames[k], &totals.local_at_gps[k]);
  }
  return totals;
}

// vo_optimized.* (RunFileNames): as vo.tum / vo.geojson / vo.kml / vo.gpx.
void WriteOptimizedTrack(const RunConfig& config, const FlightRecording& flight,
                         const OptimizedFlight& opt, const GeoReferencer& georef,
                         const std::filesystem::path& out_dir) {
  TumWriter tum(out_dir / RunFileNames::kVoOptimizedTum);
  const std::string name = FlightNameOf(config.input) + " VO optimised";
  std::optional<GeoJsonTrackWriter> geojson;
  std::optional<KmlTrackWriter> kml;
  std::optional<GpxTrackWriter> gpx;
  if (georef.ready()) {
    geojson.emplace(out_dir / RunFileNames::kVoOptimizedGeoJson, name);
    kml.emplace(out_dir / RunFileNames::kVoOptimizedKml, name, "ff00ff00");
    gpx.emplace(out_dir / RunFileNames::kVoOptimizedGpx, name);
  }
  for (std::size_t k = 0; k < opt.local_from_frame.size(); ++k) {
    const backend::Similarity2& p = opt.local_from_frame[k];
    const double t = flight.times_s[k];
    if (!georef.ready()) {
      tum.Append(t, Eigen::Vector3d(p.translation_m.x(), p.translation_m.y(), 0.0), p.heading_rad);
      continue;
    }
    const Eigen::Vector2d enu = georef.EnuFromLocal(p.translation_m);
    tum.Append(t, Eigen::Vector3d(enu.x(), enu.y(), 0.0),
               std::remainder(p.heading_rad + georef.rotation_rad(), 2.0 * M_PI));
    const GeoTrackPoint g{t, georef.TrackWgs84FromLocal(p.translation_m)};
    geojson->Append(g);
    kml->Append(g);
    gpx->Append(g);
  }
}

// summary.json "optimized"."pairs" (RunSummary::Optimized::pairs).
nlohmann::json PairsJson(const FlightRecording& flight, const OptimizedFlight& opt) {
  const auto pose = [](const backend::Similarity2& p) {
    return nlohmann::json::array(
        {p.translation_m.x(), p.translation_m.y(), p.heading_rad * kRadToDeg, p.log_scale});
  };
  nlohmann::json out = nlohmann::json::array();
  for (const TriedPair& p : opt.pairs) {
    out.push_back({{"a", flight.frames[static_cast<std::size_t>(p.a)]},
                   {"b", flight.frames[static_cast<std::size_t>(p.b)]},
                   {"verdict", ToString(p.verdict)},
                   {"inliers", p.inliers},
                   {"spread", p.spread},
                   {"fit", pose(p.fit)},
                   {"predicted", pose(p.predicted)},
                   {"down_weighted", p.down_weighted},
                   {"by_appearance", p.by_appearance}});
  }
  return out;
}

// transforms_optimized.csv (RunFileNames): frame k's world_from_frame moved by the rigid motion
// of the local plane taking its causal pose to its optimised one (C = optimised * causal^-1,
// carried into the world frame by world_from_local), then into the first frame's pixels as
// RunOutputs::AppendTransform does.
void WriteOptimizedTransforms(const FlightRecording& flight, const OptimizedFlight& opt,
                              const std::filesystem::path& out_dir) {
  if (flight.world_from_frame.size() != opt.local_from_frame.size() ||
      flight.causal.size() != opt.local_from_frame.size() || flight.world_from_frame.empty()) {
    return;
  }
  TransformsCsvWriter csv(out_dir / RunFileNames::kTransformsOptimizedCsv);
  const Eigen::Matrix3d first_px_from_world = flight.world_from_frame.front().inverse();
  const Eigen::Matrix3d& world_from_local = flight.world_from_local;
  const Eigen::Matrix3d local_from_world = world_from_local.inverse();
  for (std::size_t k = 0; k < opt.local_from_frame.size(); ++k) {
    const Eigen::Matrix3d moved = opt.local_from_frame[k].Matrix() *
                                  flight.causal[k].Matrix().inverse();
    csv.Append(flight.frames[k], first_px_from_world * world_from_local * moved *
                                     local_from_world * flight.world_from_frame[k]);
  }
}

// The run's accepted GPS fixes (not rejected, not withheld) as absolute position factors of the
// graph frames (pose = index in flight.frames), each moved into the local frame by the inverse of
// the geo-reference (enu_from_local, a rotation and a translation: odometry/georef.h), with the
// information 1 / sigma^2 per axis (backend.gps_sigma_m). None when sigma is 0 or the run is not
// geo-referenced.
std::vector<backend::AbsoluteFactor> GpsFactors(const RunConfig& config,
                                                const FlightRecording& flight,
                                                const GeoReferencer& georef,
                                                const RunTotals& totals) {
  std::vector<backend::AbsoluteFactor> out;
  const double sigma = config.backend.gps_sigma_m;
  if (!(sigma > 0.0) || !georef.ready() || !georef.has_enu()) return out;
  const Eigen::Vector2d enu_of_origin = georef.EnuFromLocal(Eigen::Vector2d::Zero());
  const Eigen::Rotation2Dd local_from_enu_rotation(-georef.rotation_rad());
  Eigen::Matrix4d information = Eigen::Matrix4d::Identity();
  information.topLeftCorner<2, 2>() *= 1.0 / (sigma * sigma);
  for (std::size_t i = 0; i < totals.gps_frames.size(); ++i) {
    if (totals.gps_rejected[i] || totals.gps_withheld[i]) continue;
    const auto it =
        std::lower_bound(flight.frames.begin(), flight.frames.end(), totals.gps_frames[i]);
    if (it == flight.frames.end() || *it != totals.gps_frames[i]) continue;
    const Eigen::Vector3d enu = georef.enu().Forward(totals.gps_geo[i]);
    backend::AbsoluteFactor f;
    f.pose = static_cast<int>(it - flight.frames.begin());
    f.local_from_frame.translation_m =
        local_from_enu_rotation * (Eigen::Vector2d(enu.x(), enu.y()) - enu_of_origin);
    f.information = information;
    out.push_back(f);
  }
  return out;
}

}  // namespace

CorrespondenceOptions PairCorrespondenceOptions(const RunConfig& config) {
  CorrespondenceOptions pair_options = config.odometry.correspondence;
  pair_options.sampler = config.odometry.relocalize_sampler;
  return pair_options;
}

void OptimizeFlight(const RunConfig& config, const FlightRecording& flight,
                    const GeoReferencer& georef, const RunTotals& totals,
                    const ReferenceTrack* truth, const std::filesystem::path& out_dir,
                    RunSummary* summary) {
  if (!flight.graph || flight.graph->num_frames() == 0) return;
  const OptimizedFlight opt = flight.graph->Optimize(
      MakeStandardPairFitter(PairCorrespondenceOptions(config), flight.graph->width(),
                             flight.graph->height()),
      config.odometry.correspondence.ransac.seed, GpsFactors(config, flight, georef, totals));
  WriteOptimizedTrack(config, flight, opt, georef, out_dir);
  WriteOptimizedTransforms(flight, opt, out_dir);
  RunSummary::Optimized o;
  o.keyframes = opt.keyframes;
  o.pairs_tried = opt.pairs_tried;
  o.pairs_verified = opt.pairs_verified;
  o.pairs_rejected = opt.pairs_rejected;
  o.pairs_gated = opt.pairs_gated;
  o.outliers = opt.outliers;
  o.closures_tried = opt.closures_tried;
  o.closures_verified = opt.closures_verified;
  o.closures_gated = opt.closures_gated;
  o.gps_factors = opt.absolute;
  o.gps_outliers = opt.absolute_outliers;
  o.match_s = opt.match_s;
  o.solve_s = opt.solve_s;
  o.iterations = opt.iterations;
  o.pairs = PairsJson(flight, opt);
  // The same comparisons as the causal track's, on a scratch summary.
  RunSummary scratch;
  RunTotals t = OptimizedTotals(flight, opt, totals);
  CompareWithGps(georef, t, &scratch);
  if (truth != nullptr && !t.local_track.empty()) {
    CompareWithTruth(*truth, t.local_track, t.track_frames, georef, &scratch);
  }
  o.evaluation = scratch.evaluation;
  o.truth_evaluation = scratch.truth_evaluation;
  if (t.denied_at_s) {
    std::string note;
    o.gps_denied_error = CompareWithWithheld(georef, t, &note);
  }
  summary->optimized = std::move(o);
}

void WriteSummary(const std::filesystem::path& out_dir, const RunSummary& summary) {
  WriteJsonFileAtomic(out_dir / RunFileNames::kSummaryJson, ToJson(summary));
  if (!summary.error.empty() && summary.frames_processed == 0) {
    throw InputError(fmt::format("{} (summary.json in '{}' says so)", summary.error,
                                 out_dir.string()));
  }
  if (!summary.error.empty()) {
    throw InputError(fmt::format(
        "{} (the run stopped there: the {} frames processed before are in '{}', each file "
        "valid, summary.json included)",
        summary.error, summary.frames_processed, out_dir.string()));
  }
}

}  // namespace aerovo::run_steps
