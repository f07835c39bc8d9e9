// The steps of one `aerovo run` (RunFlight, runner.h), each testable on its own:
//   1. the inputs: the settings sim.json fills in, the ground truth (ResolveInputs) and the
//      telemetry with its frame-index/time lookup (RunTelemetry);
//   2. the camera's focal length (ResolveRunCamera) and lens undistortion (MakeUndistorter);
//   3. the height above ground of each frame (HeightProvider);
//   4. the run's outputs: track writers, the queue of frames waiting for the geo-referencing,
//      the pose stream, transforms.csv, config.json with its "resolved" block (RunOutputs);
//   5. what the per-frame loop (pipeline/frame_loop.h FrameLoop) accumulates for the summary
//      (RunTotals) and how it ended (LoopEnd);
//   6. the summary: statistics, comparisons with GPS and the truth (Summarize), summary.json
//      (WriteSummary).
// RunFlight chains them; its API (runner.h) is the public one. These are for runner.cc and the
// pipeline's tests.
#pragma once

#include <atomic>
#include <deque>
#include <map>
#include <filesystem>
#include <map>
#include <limits>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "aerovo/core/image.h"
#include "aerovo/core/timer.h"
#include "aerovo/eval/trajectory_eval.h"
#include "aerovo/outputs/frame_record.h"
#include "aerovo/frames/frame_source.h"
#include "aerovo/frames/image_metadata.h"
#include "aerovo/telemetry/reference_track.h"
#include "aerovo/telemetry/telemetry.h"
#include "aerovo/outputs/track_writers.h"
#include "aerovo/mavlink/link.h"
#include "aerovo/mavlink/vision.h"
#include "aerovo/odometry/georef.h"
#include "aerovo/odometry/gps_check.h"
#include "aerovo/odometry/visual_odometry.h"
#include "aerovo/pipeline/preprocess.h"
#include "aerovo/pipeline/run_config.h"
#include "aerovo/pipeline/run_types.h"
#include "aerovo/pipeline/runner.h"

namespace aerovo::run_steps {

/// The GPS fix of a telemetry sample (altitude: absolute, else relative, else 0 m); nullopt
/// without a sample or when the sample has no fix (TelemetrySample::has_fix).
std::optional<GeoPoint> GpsOf(const std::optional<TelemetrySample>& sample);

// ---------------------------------------------------------------------------------------------
// 1. Inputs

/// A run's settings once sim.json has filled in what was not given, and its ground truth.
struct RunInputs {
  RunConfig config;             ///< The given configuration, completed from sim.json.
  std::string sim_manifest;     ///< The sim.json used ("" when the input is not a simulation).
  bool focal_from_sim = false;  ///< config.focal_px is sim.json's (focal source "sim.json").
  /// config.telemetry was found beside the video (the same name, .SRT), not given.
  bool telemetry_beside = false;
  /// config.telemetry is the video itself, found to hold a subtitle track (a DJI aircraft's
  /// captions, frames/video_text_track.h), not given.
  bool telemetry_in_video = false;
  std::optional<ReferenceTrack> truth;  ///< Read from config.truth (nullopt when empty).
};

/// For a flight of `aerovo simulate` (config.input is its video or frames folder and sim.json
/// sits in the folder above): telemetry = its SRT, truth = its ground_truth.csv, focal_px = its
/// exact focal_px unless focal_px or hfov_deg is given. Explicit settings win. An unreadable or
/// foreign sim.json is reported in `warnings` and ignored. Otherwise, for a video file without
/// telemetry given: the .SRT (any case) of the same name beside it, as DJI aircraft record
/// DJI_0042.MP4 and DJI_0042.SRT (telemetry_beside; not with telemetry "none"); without one, the
/// video itself when it has a subtitle track (telemetry_in_video: DJI aircraft that write no .SRT
/// caption the video inside). Then reads the truth: InputError naming the file when it cannot be
/// read.
RunInputs ResolveInputs(const RunConfig& given, std::vector<std::string>* warnings);

/// The telemetry of a run and how a frame finds its fix.
class RunTelemetry {
 public:
  RunTelemetry() = default;  ///< No telemetry.
  /// `by_frame_index`: frames find their fix by frame index (else by time); `origin` names where
  /// the fixes come from in the log (the file, or "photo EXIF/XMP").
  RunTelemetry(Telemetry telemetry, bool by_frame_index, std::string origin);

  /// Reads `path` (RunConfig::telemetry; `lenient` = RunConfig::lenient_telemetry) or, when it
  /// is empty, the EXIF/XMP of `folder`'s photos (null: no telemetry). The reader's warnings
  /// (skipped records, photos without a fix) are appended to `warnings`; photos that give no
  /// telemetry at all are a warning too, a file that cannot be read is an InputError naming it
  /// (a malformed record: also saying that --lenient-telemetry skips them).
  /// A log that says which photos its camera took (TelemetryReadResult::camera_triggers: an
  /// autopilot's CAM, camera_capture, CAMERA_FEEDBACK) and a photo folder, unless `by_time`
  /// (RunConfig::telemetry_offset_s set): photo k takes the k-th trigger's fix, by frame index,
  /// when there are as many triggers as photos and, for photos with capture times, both keep
  /// the same times since the first (a warning saying why and the by-time matching otherwise).
  static RunTelemetry Load(const std::string& path, bool lenient, const ImageFolderSource* folder,
                           std::vector<std::string>* warnings, bool by_time = false);

  bool empty() const { return telemetry_.empty(); }
  bool by_frame_index() const { return by_frame_index_; }
  /// The fixes are an autopilot log's camera triggers, one per photo (see Load).
  bool from_camera_triggers() const { return from_camera_triggers_; }
  const Telemetry& telemetry() const { return telemetry_; }
  /// Where the fixes come from (the file, or "photo EXIF/XMP").
  const std::string& origin() const { return origin_; }
  /// RunConfig::telemetry_offset_s: telemetry time at video time 0. Non-zero: every frame
  /// finds its fix by time (frame.time_s + offset_s), also in a telemetry with frame indices.
  void set_offset_s(double offset_s) { offset_s_ = offset_s; }
  double offset_s() const { return offset_s_; }
  /// The fix of `frame`: by frame index when the telemetry has one for every fix (DJI SRT,
  /// photos, CSV with a frame column) and no offset is set, else the interpolated fix at
  /// frame.time_s + offset_s (within 0.5 s of the covered span); nullopt without telemetry or
  /// when none matches.
  std::optional<TelemetrySample> SampleOf(const Frame& frame) const;
  /// Where the fix of the frame with this index and capture time was read
  /// (TelemetrySample::origin of SampleOf); empty when unknown. Looked up again when a message
  /// needs it, so that a run keeps no per-frame record of it.
  std::string OriginOf(int frame_index, double time_s) const;
  /// Why `frame` has no fix (SampleOf gave nothing), in words: the frame's time or index against
  /// the telemetry's span, e.g. "frame 0 is before the first telemetry record (FrameCnt 1001:
  /// the second clip of a split recording?)".
  std::string WhyNoFix(const Frame& frame) const;
  /// For a frame before the telemetry's first record (SampleOf gave nothing) and close to it, the
  /// first record with a relative altitude: at most kMaxLeadFrames frames before the first
  /// record (telemetry by frame index: a first record skipped as malformed, captions that start
  /// at the second frame) or kMaxLeadS seconds before it, beyond SampleOf's 0.5 s (by time: a
  /// log started after the camera). nullopt otherwise: a frame far before the first record
  /// belongs to other telemetry (the second clip of a split recording), one after it has no
  /// record for another reason.
  std::optional<TelemetrySample> FirstRecordAhead(const Frame& frame) const;
  static constexpr int kMaxLeadFrames = 30;
  static constexpr double kMaxLeadS = 2.0;
  /// The log's description: "none" or "N fixes from ORIGIN".
  std::string Describe() const;

 private:
  Telemetry telemetry_;
  bool by_frame_index_ = false;
  bool from_camera_triggers_ = false;
  std::string origin_;
  double offset_s_ = 0.0;
};

// ---------------------------------------------------------------------------------------------
// 2. Camera

/// The focal length of the processed frames and where it came from.
struct RunCamera {
  double focal_px = 0.0;
  /// RunSummary::focal_source: "calibration", "flag", "sim.json", "hfov", "xmp-calibrated",
  /// "exif-35mm", "exif-focal-plane" or "telemetry-35mm".
  std::string focal_source;
  /// The same as a sentence for the run log (frames/camera.h ResolvedCamera::source), e.g. "focal
  /// length 2311.2 px from EXIF FocalLengthIn35mmFilm 20 mm of 'a.jpg' over the FC300S's 4:3
  /// sensor".
  std::string description;
  /// The calibrated camera of the frames (config.calibration, scaled to the frames' size);
  /// unset without a calibration file.
  std::optional<CameraIntrinsics> calibrated;
};

/// The focal length of width_px x height_px frames by frames/camera.h ResolveCamera (the one focal
/// chain): config.focal_px ("flag", or "sim.json" when `focal_from_sim`), config.hfov_deg
/// ("hfov"), the first photo's DJI XMP calibrated focal length when the photo has the frames'
/// size ("xmp-calibrated"), its EXIF 35 mm equivalent ("exif-35mm"), its EXIF focal length over
/// its pixel pitch at the frames' size ("exif-focal-plane"), the first frame's telemetry
/// 35 mm equivalent ("telemetry-35mm"). `photo`: the first photo's metadata (null for a video or
/// a live source); `sample`: the first frame's telemetry fix. InputError naming `frame_name`
/// when none gives it.
RunCamera ResolveRunCamera(const RunConfig& config, bool focal_from_sim, int width_px,
                           int height_px, const ImageMetadata* photo,
                           const std::optional<TelemetrySample>& sample,
                           const std::string& frame_name);

/// The undistorter of the lens coefficients config.k1 k2 p1 p2 k3 for width_px x height_px
/// frames of focal length focal_px; null when every coefficient is 0 (frames used as read).
std::unique_ptr<FrameUndistorter> MakeUndistorter(const RunConfig& config, int width_px,
                                                  int height_px, double focal_px);
/// The distorted camera of width_px x height_px frames (the frames after FrameReducer, focal
/// focal_px): the calibration scaled to them (RunCamera::calibrated), else the centred pinhole
/// with config.k1 k2 p1 p2 k3; unset when it is already the centred pinhole without distortion.
std::optional<CameraIntrinsics> RunLens(const RunConfig& config, const RunCamera& camera,
                                        int width_px, int height_px, double focal_px);
/// The path RunConfig::undistort takes for `lens`: kFrames or kPoints (kAuto resolved with
/// camera/lens.h MaxLensScaleChange <= kPointsMaxScaleChange; `scale_change` receives it).
UndistortMode ChooseUndistortion(UndistortMode mode, const CameraIntrinsics& lens,
                                 double* scale_change);
/// The undistorter of a calibrated camera (RunCamera::calibrated) scaled to width_px x
/// height_px (the frames after FrameReducer); null when it is already the centred pinhole
/// without distortion.
std::unique_ptr<FrameUndistorter> MakeUndistorter(const CameraIntrinsics& calibrated,
                                                  int width_px, int height_px);

// ---------------------------------------------------------------------------------------------
// 3. Height above ground

/// The height above ground of each frame: the flag, else the autopilot's (MAVLink, udpin/serial:
/// a downward rangefinder, else GLOBAL_POSITION_INT.relative_alt, the sample nearest the frame's
/// capture time), else the telemetry's relative altitude, else the last known one (with one
/// warning), else an error naming the frame.
class HeightProvider {
 public:
  /// `flag_m` > 0 (RunConfig::altitude_m): that height for every frame; else the link's (`link`
  /// may be null; samples within `match_s` of the frame), else the telemetry's.
  explicit HeightProvider(double flag_m, const mavlink::AutopilotLink* link = nullptr,
                          double match_s = 0.25)
      : flag_m_(flag_m), link_(link), match_s_(match_s) {}
  /// RunSummary::height_source: kFlag, kMavlink or kTelemetry.
  HeightSource source() const {
    return flag_m_ > 0.0         ? HeightSource::kFlag
           : link_ != nullptr    ? HeightSource::kMavlink
                                 : HeightSource::kTelemetry;
  }
  /// Height above ground of frame `frame_name`, metres: the flag; else the link's sample nearest
  /// `capture_s` (MonotonicNowS clock) within match_s (for the first frame, when none is that
  /// close, the newest sample); else the sample's relative altitude when > 0; else, for a frame
  /// without a sample before any height is known, the first record ahead's
  /// (set_first_record_ahead; the first time, a warning); else the last one known (the first
  /// time, a warning naming the frame is appended to `warnings`); else InputError naming the
  /// frame.
  double HeightOf(const std::string& frame_name, const std::optional<TelemetrySample>& sample,
                  std::vector<std::string>* warnings, double capture_s = 0.0);
  /// The telemetry's first record ahead of a frame that has none (RunTelemetry::
  /// FirstRecordAhead): while no height is known, its relative altitude stands in for such a
  /// frame's (source kFirstRecord, one warning naming the frame and the record). Set by the
  /// height stage before HeightOf; nullopt clears it.
  void set_first_record_ahead(std::optional<TelemetrySample> record) {
    first_record_ahead_ = std::move(record);
  }
  /// Where the last HeightOf came from.
  FrameHeightSource last_kind() const { return last_source_; }
  /// The same as FrameRecord::height_source writes it ("altitude_flag", "telemetry", ...).
  std::string last_source() const { return ToString(last_source_); }
  /// Why there is no height for the first frame (the message of HeightOf's InputError):
  /// RunTelemetry::WhyNoFix when `sample` is missing; "the telemetry has no relative altitude"
  /// when it lacks one; "relative altitude -3.0 m <= 0 (the aircraft below its take-off point?)"
  /// when it is not positive. Set by the FrameLoop before HeightOf.
  void set_no_fix_reason(std::string reason) { no_fix_reason_ = std::move(reason); }
  /// The last height used, if any.
  std::optional<double> last_m() const { return last_m_; }
  /// How a telemetry altitude becomes a height above ground (RunConfig ground_elevation_m,
  /// takeoff_height_agl_m): a relative altitude (above the take-off point) plus
  /// `takeoff_height_agl_m` (source "telemetry", or "telemetry_rel_alt+takeoff_height" when the
  /// offset is not 0); without one, an altitude above sea level minus `ground_elevation_m` when
  /// that is known (source "telemetry_abs_alt-ground_elevation"), else InputError naming the
  /// frame (a photo: its file) or `telemetry_name` and the altitude found. Set before HeightOf.
  void set_ground(double ground_elevation_m, double takeoff_height_agl_m,
                  std::string telemetry_name = {}) {
    ground_elevation_m_ = ground_elevation_m;
    takeoff_height_agl_m_ = takeoff_height_agl_m;
    telemetry_name_ = std::move(telemetry_name);
  }

 private:
  double flag_m_ = 0.0;
  const mavlink::AutopilotLink* link_ = nullptr;
  double match_s_ = 0.25;
  std::optional<double> last_m_;
  bool warned_ = false;
  FrameHeightSource last_source_ = FrameHeightSource::kNone;
  std::string no_fix_reason_;
  std::optional<TelemetrySample> first_record_ahead_;
  bool warned_ahead_ = false;
  double ground_elevation_m_ = std::numeric_limits<double>::quiet_NaN();
  double takeoff_height_agl_m_ = 0.0;
  std::string telemetry_name_;
};

/// The camera attitude of one frame and where it came from (RunConfig::attitude).
struct FrameAttitude {
  /// Given to VisualOdometry::Process; none when attitude is off, no source has one, or the
  /// tilt is below attitude_min_deg.
  std::optional<CameraAttitude> camera;
  /// The attitude the sources give, used or not (for the warning of attitude_warn_deg).
  std::optional<CameraAttitude> reported;
  /// The reported attitude would put a frame corner within kMinCornerDepressionDeg of the
  /// horizon or above it (odometry/attitude.h LowestCornerDepressionDeg): no nadir view can be
  /// made of the frame, so `camera` is left unset (the attitude stage).
  bool beyond_nadir_view = false;
  /// kGimbal (the telemetry's gimbal angles), kMavlink (the autopilot's ATTITUDE, camera fixed
  /// to the airframe), kFlight (the telemetry's aircraft angles, camera fixed), kMount (the mount
  /// pitch, the aircraft taken as level), kEstimated (the flight's own estimate), kNone.
  AttitudeSource source = AttitudeSource::kNone;
};
/// The camera attitude of a frame: the telemetry's gimbal pitch and roll (camera pitch = gimbal
/// pitch + 90, roll = gimbal roll; either missing = 0), else the autopilot's attitude `link`,
/// else the telemetry's aircraft pitch and roll; an aircraft's angles make the camera's through
/// level_from_camera = Ry(pitch) Rx(roll) Ry(camera_mount_pitch_deg) (odometry/attitude.h);
/// else the mount pitch alone, else the flight's own estimate `estimated`
/// (RunContext::estimated_attitude).
FrameAttitude CameraAttitudeOf(const RunConfig& config,
                               const std::optional<TelemetrySample>& sample,
                               const std::optional<mavlink::AutopilotAttitude>& link,
                               const std::optional<CameraAttitude>& estimated = std::nullopt);

// ---------------------------------------------------------------------------------------------
// 4. Outputs

/// A frame whose outputs wait for the geo-referencing (heading from the first GPS segment).
struct PendingFrame {
  FrameRecord record;  ///< Counts, stage times, status; position and yaw filled in when written.
  Eigen::Vector2d local_m = Eigen::Vector2d::Zero();  ///< Position in the local VO frame.
  double heading_rad = 0.0;                           ///< In the local VO frame.
  std::optional<GeoPoint> gps;                        ///< The frame's fix.
  double height_m = 0.0;  ///< Height above ground used for the frame (pose stream z_m).
  int quality = -1;       ///< PoseQuality (pipeline/pose_quality.h).
  /// backend.online: the windowed pose's standard deviations given the final poses before the
  /// window (FlightGraph::AddOnline's covariance: the larger axis of the position's, metres; the
  /// heading's, degrees); NaN when there is none (pose stream "sigma_xy_m", "sigma_heading_deg").
  double sigma_xy_m = std::numeric_limits<double>::quiet_NaN();
  double sigma_heading_deg = std::numeric_limits<double>::quiet_NaN();
  bool sent_geo = false;  ///< The pose stream already has its geographic position.
};

/// A frame's pose as the lens switch's replay estimated it (pipeline/lens_switch.h): the run's
/// files take it in place of the live one (RunOutputs::ReleaseHeld, RunTotals::ReplacePoses).
struct ReplayedPose {
  int frame = -1;      ///< Frame::index.
  FrameResult result;  ///< The replay odometry's result (its features released).
  /// result.world_from_frame in full-frame pixels (times RunContext::reduced_from_full when
  /// reduced), as transforms.csv takes it (RunOutputs::AppendTransform).
  Eigen::Matrix3d world_from_full = Eigen::Matrix3d::Identity();
};

/// `p` given the replayed pose `r` (ReplayedPose): its local position, heading and quality, and
/// its record's feature counts, cluster and status (the odometry's part; the suffixes after it,
/// "+" a frame flag, kept). The stage times stay the live run's.
void ReplacePose(PendingFrame& p, const FrameResult& r);

/// A GPS fix rejected by the plausibility check (gps_check.h), for the summary.
struct RejectedFix {
  int frame = 0;
  double time_s = 0.0;   ///< The frame's time, s.
  std::string kind;      ///< "speed", "altitude", "vo" or "superseded".
  std::string message;   ///< "<telemetry>: the fix of frame N (time t s) rejected: <reason>".
};

/// The pending frame of `frame` processed into `result`, with its fix `gps` and its height
/// above ground `height_m`.
PendingFrame PendingFrameOf(const Frame& frame, const FrameResult& result,
                            const std::optional<GeoPoint>& gps, double height_m = 0.0);

/// The pose stream (RunConfig::poses_jsonl): one JSON object per line, flushed when written.
///   {"type":"pose", "index", "time_s", "x_m", "y_m", "z_m", "heading_deg", "status",
///    "quality", "latency_ms"[, "sigma_xy_m", "sigma_heading_deg"][, "lat_deg", "lon_deg", "east_m",
///    "north_m", "yaw_enu_deg"]}
/// once per frame as soon as the frame is done (never held back): index = Frame::index,
/// time_s = the capture time (Frame::time_s: video time, photo time, seconds since a live
/// source opened), x_m/y_m = the local VO frame (metres, x = first image right, y = first image
/// up), z_m = the height above ground used, heading_deg = the image x axis in the local frame
/// (counter-clockwise from local x), status as in frames.csv ("ok", "bridged:too-few-inliers",
/// ...), quality = PoseQuality (0-100, -1 bridged), latency_ms = capture to this line (null
/// when unmeasured); with backend.online, x_m/y_m/heading_deg are the online window's estimate
/// and sigma_xy_m/sigma_heading_deg its standard deviations given the final poses before the
/// window (PendingFrame). The geographic fields (WGS84 lat/lon, ENU east/north from the first fix,
/// yaw of the image x axis in ENU counter-clockwise from east) are there when the track is
/// already geo-referenced. A frame sent without them while the heading waits for the first
/// GPS segment gets, as soon as the heading is fixed, one
///   {"type":"geo", "index", "time_s", "lat_deg", "lon_deg", "east_m", "north_m", "yaw_enu_deg"}
/// (in frame order, before the next pose line). No other line is written.
std::string PoseJsonLine(const PendingFrame& frame, const GeoReferencer& georef);
/// The "geo" line of `frame` (georef.ready()).
std::string GeoJsonLine(const PendingFrame& frame, const GeoReferencer& georef);

/// The files a run writes as it goes (RunFileNames): the track writers (frames.csv, TUM,
/// GeoJSON, KML, GPX), transforms.csv and config.json with the "resolved" block; plus the pose
/// stream and the frame callback. Frames are queued until the track is geo-referenced when
/// the run waits for a heading, then written in order.
class RunOutputs {
 public:
  /// Opens the track writers in `out_dir` (ENU origin: the run's, GeoReferencer::enu(), set
  /// when the first frame is written; time origin: `first_sample`'s unix time minus
  /// first_time_s), writes config.json (ToJson(config) and a "resolved" block:
  /// focal_px, focal_source, height_source, frame_width_px, frame_height_px) and opens
  /// transforms.csv. `wait_for_heading`: the run has GPS telemetry, so frames wait for the
  /// geo-referencing (bounded: GeoRefOptions::min_segment_m). `callbacks` (frame, poses) must
  /// outlive the outputs. InputError naming a file that cannot be written.
  RunOutputs(const std::filesystem::path& out_dir, const RunConfig& config, const RunCamera& camera,
             const std::string& height_source, int width_px, int height_px, double first_time_s,
             const std::optional<TelemetrySample>& first_sample, const RunCallbacks& callbacks,
             bool wait_for_heading);

  /// Appends the row of `frame_index` to transforms.csv: first_px_from_frame =
  /// first_px_from_world * world_from_frame, first_px_from_world being the inverse of the first
  /// call's world_from_frame (metric or first-frame pixels, see FrameResult).
  void AppendTransform(int frame_index, const Eigen::Matrix3d& world_from_frame);
  /// SendPose then Enqueue.
  void Add(PendingFrame frame, const GeoReferencer& georef);
  /// Sends `frame` to the pose stream (RunConfig::poses_jsonl; nothing without one) at once, in
  /// the local frame while `georef` waits for the heading (frame.sent_geo says whether its
  /// geographic position went with it). OutputError/InputError when the stream cannot take it.
  void SendPose(PendingFrame& frame, const GeoReferencer& georef);
  /// Queues `frame`, then writes the queue unless it waits for `georef`'s heading.
  void Enqueue(PendingFrame frame, const GeoReferencer& georef);
  /// The frames no longer wait for the heading (GPS denied before it was known): the queue is
  /// written with the next frame, in the local frame.
  void StopWaitingForHeading() { wait_for_heading_ = false; }
  /// Sets the gps_flag of the queued frame `frame_index` (no effect once it is written).
  void Reflag(int frame_index, const std::string& gps_flag);
  /// The lens switch's replay will re-estimate the first frames (pipeline/lens_switch.h): from
  /// now on the frames queued (Enqueue: frames.csv, the vo.* tracks, the frame callback,
  /// --print-poses, the pose stream's "geo" lines) and the transforms.csv rows are held, not
  /// written, until ReleaseHeld. The pose stream's "pose" lines (SendPose) are not held.
  void HoldForReplay() { hold_for_replay_ = true; }
  /// Gives the held frames the poses of `replayed` (ascending frames; a frame not among them
  /// keeps its own: ReplacePose), writes the held transforms.csv rows (the replayed ones' from
  /// ReplayedPose::world_from_full) and stops holding: the queue is written with the next frame
  /// (Enqueue) or at Finish, after the geo-referencing the caller rebuilt.
  void ReleaseHeld(const std::vector<ReplayedPose>& replayed);
  /// At the end: geo-references with what is available if needed (georef.FixWithAvailable),
  /// writes every queued frame (the held ones as they are) and closes the track files.
  void Finish(GeoReferencer& georef);
  /// Rows written to frames.csv so far (frames still queued for the heading are not).
  int frames_written() const;

 private:
  void Flush(const GeoReferencer& georef, bool final);
  void Emit(PendingFrame& frame, const GeoReferencer& georef);

  const RunCallbacks& callbacks_;
  bool wait_for_heading_ = false;
  std::unique_ptr<TrackWriterSet> writers_;
  std::optional<TransformsCsvWriter> transforms_csv_;
  bool have_first_ = false;
  Eigen::Matrix3d first_px_from_world_ = Eigen::Matrix3d::Identity();
  std::deque<PendingFrame> pending_;
  bool hold_for_replay_ = false;  // HoldForReplay until ReleaseHeld
  // transforms.csv rows held (frame index, world_from_frame in full-frame pixels).
  std::vector<std::pair<int, Eigen::Matrix3d>> held_transforms_;
  std::unique_ptr<std::ostream> jsonl_file_;  // RunConfig::poses_jsonl when a file
  std::ostream* jsonl_ = nullptr;             // the pose stream: jsonl_file_ or stdout
  std::string jsonl_name_;                    // for messages
};

// ---------------------------------------------------------------------------------------------
// 5. The per-frame loop

/// What the summary needs from the frames, accumulated as they are processed. The only memory
/// that grows with the run (the rest of the per-frame output is streamed to the files): per
/// frame with a GPS fix, the VO position (local frame), the fix (ENU), its frame and flag, 53
/// bytes; every frame's VO position and index, 28 bytes (the FrameLoop keeps the track always:
/// the truth and the telemetry offset estimate use it); every frame's latency, 4 bytes.
struct RunTotals {
  explicit RunTotals(bool keep_track) : keep_track(keep_track) {}
  /// Adds frame `frame_index` at `time_s` processed into `result`, with its fix `gps` (kept as
  /// WGS84 in gps_geo: the comparison with GPS uses the run's ENU frame as it is at the end,
  /// whose origin is a fix that was accepted, odometry/georef.h).
  /// `withheld`: the fix was withheld by GPS denial (compared, never used).
  void Add(int frame_index, double time_s, const FrameResult& result,
           const std::optional<GeoPoint>& gps, bool withheld = false);

  /// Marks the fix of `frame_index` rejected (true) or accepted again: rejected fixes are left
  /// out of the comparison with GPS.
  void SetRejected(int frame_index, bool rejected);

  /// The positions of the frames of `replayed` (ascending frames, pipeline/lens_switch.h) in
  /// place of theirs in the track (local_track, local_at_gps), path_length_m and last_local_m
  /// recomputed from the track. Precondition: keep_track. The counts stay the live run's.
  void ReplacePoses(const std::vector<ReplayedPose>& replayed);

  bool keep_track = false;  ///< Keep every frame's position (local_track) for the truth.
  int frames = 0;
  int measured_steps = 0;  ///< Frames whose step was estimated (ok or reacquired).
  int frames_with_gps = 0;
  double path_length_m = 0.0;
  StageTimes sum_ms;  ///< Sum of the stage times, ms.
  Eigen::Vector2d last_local_m = Eigen::Vector2d::Zero();
  std::vector<TrajectoryPoint2D> local_at_gps, gps_track, local_track;
  std::vector<int> track_frames;  ///< Frame index of each local_track point.
  /// Capture-to-send latency of every frame where measured, ms (4 bytes per frame).
  std::vector<float> latency_ms;
  std::vector<int> gps_frames;    ///< Frame index of each gps_track point.
  /// The fix of each gps_track point (gps_track holds its time; its x/y are set in the run's
  /// final ENU frame by the comparison with GPS).
  std::vector<GeoPoint> gps_geo;
  std::vector<char> gps_rejected;  ///< Per gps_track point: rejected by the plausibility check.
  std::vector<char> gps_withheld;  ///< Per gps_track point: withheld by GPS denial.
  /// GPS denial (RunConfig::gps_denied_after_s): the first denied frame's index and Frame::time_s
  /// (set by ReadFrame; nullopt: no frame was denied).
  std::optional<double> denied_at_s;
  int denied_from_frame = -1;
  double first_time_s = 0.0, last_time_s = 0.0;  ///< Of the processed frames.
};

/// How the frame loop ended.
struct LoopEnd {
  bool stopped = false;  ///< By the stop flag.
  /// The error that stopped the run (none: the source ended, max_frames or the stop flag).
  std::optional<RunFailure> failure;
  int frames_without_fix = 0;  ///< Frames given no telemetry fix.
  /// The first frame flagged by the source with each flag (Frame::flags), for the warning.
  std::map<std::string, std::string> first_flagged;
  /// A write to an output file failed (failure of kind kOutput): the files stay valid but
  /// the frames still queued cannot be written (skip FrameLoop::Finish).
  bool output_failed() const { return failure && failure->kind == RunFailureKind::kOutput; }
  /// The fixes rejected by the plausibility check, by frame.
  std::vector<RejectedFix> rejected_fixes;
};

// ---------------------------------------------------------------------------------------------
// 6. Summary

/// Completes `summary` after the loop (its frames_processed, focal and height already set):
/// the source's warnings, frames without a fix (when there is telemetry), one warning per flag
/// of the frames the source flagged (count, first frame, meaning), interrupted, the
/// odometry's counts (`vo_stats` null: no frame) and the warning when nothing was measured,
/// heading source, mean stage times, fps from `wall_s`, the comparison with GPS (at least 3
/// fixes, withheld ones included), the GPS denial's error against the withheld fixes
/// (summary->gps_denied, when RunFlight set it) and the comparison with `truth` (may be null), the latency's median, 95th percentile and maximum,
/// a warning when summary->frames_dropped > 0, error = end.failure's text. `totals` is consumed.
void Summarize(const std::vector<std::string>& source_warnings, bool has_telemetry,
               const LoopEnd& end, const OdometryStats* vo_stats, const GeoReferencer& georef,
               RunTotals totals, const ReferenceTrack* truth, double wall_s, RunSummary* summary);

// ---------------------------------------------------------------------------------------------
// 7. The offline whole-flight optimisation (RunConfig::backend, odometry/flight_graph.h)

/// What the flight graph sink (sink_flight_graph.cc) records: the graph of the frames processed,
/// and each graph frame's source frame index and time (s), in order.
struct FlightRecording {
  std::unique_ptr<FlightGraph> graph;
  std::vector<int> frames;
  std::vector<double> times_s;
  /// Per graph frame, for transforms_optimized.csv: world_from_frame as the transforms sink
  /// writes it (FrameResult::world_from_frame, full-frame pixels), and the causal pose
  /// local_from_frame (FrameResult position_m, heading_rad; backend/similarity2.h).
  std::vector<Eigen::Matrix3d> world_from_frame;
  std::vector<backend::Similarity2> causal;
  /// The odometry's world frame from the local one (pose_chain.h): the identity in the metric
  /// scale mode, first-frame pixels from local metres in the affine-chain mode.
  Eigen::Matrix3d world_from_local = Eigen::Matrix3d::Identity();

  /// The graph, made on the first call for frames of width x height pixels (the odometry's);
  /// `seed`: the run's seed (the keyframe signatures' projections, FlightGraph).
  FlightGraph& GraphOf(const BackendOptions& options, int width, int height,
                       std::uint64_t seed) {
    if (!graph) graph = std::make_unique<FlightGraph>(options, width, height, seed);
    return *graph;
  }
};

/// How the back-end matches a pair of keyframes (offline) or a frame and a recent keyframe
/// (online): the odometry's correspondence options with its relocalisation sampler.
CorrespondenceOptions PairCorrespondenceOptions(const RunConfig& config);

/// After the loop, with backend.enable and at least one frame recorded: the candidate pairs,
/// their fits (the odometry's correspondence options, standard method, its relocalisation
/// sampler, each pair seeded from ransac.seed) and the solve (FlightGraph::Optimize); writes
/// vo_optimized.tum (the run's ENU frame when geo-referenced, else local; as vo.tum) and, once
/// geo-referenced, vo_optimized.geojson, .kml and .gpx; fills in summary->optimized with the
/// counts, the times and the optimised track against GPS and `truth` (may be null), as
/// Summarize compares the causal track (`totals`: the causal totals, before Summarize consumes
/// them). OutputError naming a file that cannot be written.
void OptimizeFlight(const RunConfig& config, const FlightRecording& flight,
                    const GeoReferencer& georef, const RunTotals& totals,
                    const ReferenceTrack* truth, const std::filesystem::path& out_dir,
                    RunSummary* summary);

/// Writes summary.json in `out_dir`; then, when summary.error is set, throws it as an InputError
/// saying where the frames before it are.
void WriteSummary(const std::filesystem::path& out_dir, const RunSummary& summary);

}  // namespace aerovo::run_steps
