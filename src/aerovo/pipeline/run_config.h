// The configuration of one `aerovo run`: every option a run can be told, as flags (cli/run_cli.cc)
// or as a JSON/YAML config file with the same keys; validation, JSON conversion and parsing, all
// generated from one field list (VisitFields below and the stages' lists it includes; the
// machinery is core/options.h). docs/options.md lists every key.
#pragma once

#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "aerovo/core/options.h"
#include "aerovo/features/flat_field.h"
#include "aerovo/frames/video_decoder_choice.h"
#include "aerovo/mavlink/vision.h"
#include "aerovo/odometry/georef.h"
#include "aerovo/odometry/gps_check.h"
#include "aerovo/odometry/map_match.h"
#include "aerovo/odometry/flight_graph.h"
#include "aerovo/odometry/visual_odometry.h"

namespace aerovo {

/// RunConfig::telemetry of a run without telemetry: no .SRT found beside the video nor the
/// video's subtitle track is used, and a photo folder's EXIF/XMP is not read as telemetry.
inline constexpr const char* kNoTelemetry = "none";

template <>
struct options::EnumTraits<HeadingSource>
    : options::EnumList<HeadingSource, ToString, HeadingSource::kAuto, HeadingSource::kTelemetryYaw,
                        HeadingSource::kGpsSegment> {};

template <>
struct options::EnumTraits<mavlink::VisionMessageKind>
    : options::EnumList<mavlink::VisionMessageKind, mavlink::ToString,
                        mavlink::VisionMessageKind::kOdometry,
                        mavlink::VisionMessageKind::kVisionPositionEstimate,
                        mavlink::VisionMessageKind::kVisionPositionDelta> {};
template <>
struct options::EnumTraits<mavlink::TimestampClock>
    : options::EnumList<mavlink::TimestampClock, mavlink::ToString, mavlink::TimestampClock::kBoot,
                        mavlink::TimestampClock::kUnix> {};

/// Whether the run corrects for the camera's attitude (RunConfig::attitude).
enum class AttitudeMode {
  kAuto,  ///< The telemetry's camera attitude when it has one (run_steps.h CameraAttitudeOf).
  kOff,   ///< Every frame processed as a nadir frame.
};
inline const char* ToString(AttitudeMode m) { return m == AttitudeMode::kAuto ? "auto" : "off"; }
template <>
struct options::EnumTraits<AttitudeMode>
    : options::EnumList<AttitudeMode, ToString, AttitudeMode::kAuto, AttitudeMode::kOff> {};

/// How a run undoes lens distortion (RunConfig::undistort; docs/lenses.md "Points or whole frames").
enum class UndistortMode {
  kAuto,    ///< kPoints when the lens's local scale change is small (camera/lens.h), else kFrames.
  kFrames,  ///< Every frame remapped before SURF (frames/camera.h Undistorter, one cv::remap).
  kPoints,  ///< SURF on the distorted frame, its keypoints undistorted (camera/lens.h).
};
inline const char* ToString(UndistortMode m) {
  return m == UndistortMode::kAuto ? "auto" : m == UndistortMode::kFrames ? "frames" : "points";
}
template <>
struct options::EnumTraits<UndistortMode>
    : options::EnumList<UndistortMode, ToString, UndistortMode::kAuto, UndistortMode::kFrames,
                        UndistortMode::kPoints> {};

/// Whether a run estimates the lens from the flight itself (RunConfig::lens_estimation;
/// docs/lenses.md "Self-calibration").
enum class LensEstimationMode {
  kAuto,  ///< When no calibration file and no distortion are given and the input can be re-read.
  kOff,   ///< Never.
};
inline const char* ToString(LensEstimationMode m) {
  return m == LensEstimationMode::kAuto ? "auto" : "off";
}
template <>
struct options::EnumTraits<LensEstimationMode>
    : options::EnumList<LensEstimationMode, ToString, LensEstimationMode::kAuto,
                        LensEstimationMode::kOff> {};

/// Whether a run estimates the camera's tilt from the flight itself (RunConfig::
/// attitude_estimation; docs/attitude.md "Estimated from the flight").
enum class AttitudeEstimationMode {
  kAuto,  ///< A photo folder when nothing gives the camera's attitude.
  kOff,   ///< Never.
};
inline const char* ToString(AttitudeEstimationMode m) {
  return m == AttitudeEstimationMode::kAuto ? "auto" : "off";
}
template <>
struct options::EnumTraits<AttitudeEstimationMode>
    : options::EnumList<AttitudeEstimationMode, ToString, AttitudeEstimationMode::kAuto,
                        AttitudeEstimationMode::kOff> {};

/// Everything a run can be told, as flags (cmd_run.cc) or as a JSON config file with the same
/// keys (ToJson / RunConfigFromJson). Plain aggregate; Validate() checks it.
struct RunConfig {
  /// Video file, image folder, camera index, device path or stream URL (frames/frame_source.h).
  std::string input;
  /// Telemetry file (.srt, .gpx, .csv, ...); empty: for a video, the .SRT of the same name beside
  /// it if there is one (as DJI aircraft record them), for a folder the photos' EXIF/XMP;
  /// "none": no telemetry at all (kNoTelemetry).
  std::string telemetry;
  /// Malformed telemetry records (garbage line, missing latitude, out-of-range value, timestamp
  /// out of order): false (default) = the run stops with an error naming the file and line;
  /// true = they are skipped, counted and reported in the summary's warnings (their frames then
  /// have no GPS). Default false: a damaged file is worth a look before trusting it.
  bool lenient_telemetry = false;
  /// Ground-truth track to compare with, beside GPS (telemetry/reference_track.h: the simulator's
  /// ground_truth.csv / .tum, any TUM file, or a telemetry file with positions); matched to the
  /// frames by frame index when the file gives one for every point (CSV frame column, SRT), else
  /// by time. Empty: none, or the simulator's ground_truth.csv when sim.json is found.
  std::string truth;
  /// Output folder (created). Default "aerovo-run".
  std::string out = "aerovo-run";
  /// Process every k-th frame (video; photos: every k-th photo). Default 1.
  int step = 1;
  /// Time window of the source, seconds (end < 0: to the end).
  double start_s = 0.0;
  double end_s = -1.0;
  /// Stop after this many processed frames (0 = all).
  int max_frames = 0;
  /// Files (video, photo folder): deliver each frame no earlier than its own time, the first
  /// frame's read plus its presentation time in the stream, as a camera would deliver it; for
  /// bench replays against an autopilot, whose timestamp filter absorbs an offset but not a
  /// file read faster than it was filmed (docs/autopilot.md). Live sources: no effect.
  bool realtime = false;
  /// Heading of the VO track in ENU: kAuto (default: telemetry yaw, else first GPS segment),
  /// kTelemetryYaw ("yaw"), kGpsSegment ("gps").
  HeadingSource heading = HeadingSource::kAuto;
  /// Height above ground, metres; when > 0 it overrides telemetry (tampa-phantom3 has none).
  /// At most 100 km (the telemetry readers' altitude limit): larger heights make non-finite
  /// geometry.
  double altitude_m = 0.0;
  /// Focal length in pixels of the processed frames; when 0, from hfov_deg, else from the
  /// telemetry/EXIF (XMP calibrated focal, else 35 mm equivalent). 0 or in [1, 1e6] px.
  double focal_px = 0.0;
  /// Horizontal field of view, degrees (used when focal_px is 0).
  double hfov_deg = 0.0;
  /// Aspect ratio (long / short side) of the sensor's full frame, which a photo's EXIF 35 mm
  /// equivalent refers to; 0 = from the camera model, else 4:3 for photos wider than 1.7:1,
  /// else the photo's own (frames/camera.h SensorAspectOf).
  double sensor_aspect = 0.0;
  /// Photo folders: a gap between capture times longer than this, or a change of camera, starts
  /// another flight (frames/frame_source.h FrameSourceOptions::photo_gap_s); 0 = no gap check.
  double photo_gap_s = 600.0;
  /// Photo folders holding several flights: 0 refuses them (the error lists the flights), K
  /// processes flight K alone, -1 chains them all.
  int photo_flight = 0;
  /// Photo folders of a multi-camera payload (multispectral cameras, DJI's wide/zoom/thermal
  /// payloads: one photo per camera at each capture): the band or camera read
  /// (frames/frame_source.h FrameSourceOptions::photo_band); empty = wide, else visible, RGB,
  /// green, blue, else the payload's first camera; "WxH" the photos of one size when the photos
  /// name no camera.
  std::string photo_band;
  /// Video files: auto (= ffmpeg, default), ffmpeg (frames/video_decoder.h: grey from the luma
  /// plane, every frame's size checked) or opencv (cv::VideoCapture); FrameSourceOptions::
  /// video_decoder.
  VideoDecoderChoice video_decoder = VideoDecoderChoice::kAuto;
  /// Video files through the ffmpeg decoder: codec threads, 0 = one per core; default 2
  /// (FrameSourceOptions::video_threads says why).
  int video_threads = 2;
  /// Lens distortion (OpenCV / Brown-Conrady model, coefficients on coordinates normalised by
  /// the focal length, principal point at the image centre): when any is non-zero every frame is
  /// undistorted (cv::remap with maps computed once) before SURF. Default 0 (none; DJI nadir
  /// photos and videos are usually already corrected in camera).
  double k1 = 0.0, k2 = 0.0, p1 = 0.0, p2 = 0.0, k3 = 0.0;
  /// Camera calibration file (camera_files/calibration.h ReadCalibration: OpenCV YAML/XML from
  /// calibrateCamera, OpenDroneMap cameras.json, COLMAP cameras.txt; pinhole or fisheye lens).
  /// When given it is the camera: focal lengths, principal point and distortion, scaled to the
  /// frames when only the resolution differs; it wins over focal_px, hfov_deg, EXIF, telemetry
  /// and k1..k3 (which must then be 0). Frames are undistorted before SURF to the centred pinhole
  /// of focal fx (frames/camera.h Undistorter). Default none (docs/lenses.md).
  std::string calibration;
  /// How the lens distortion (k1..k3, p1, p2 or the calibration) is undone: kFrames remaps every
  /// frame before SURF; kPoints runs SURF on the distorted frame and undistorts its keypoints
  /// (odometry/visual_odometry.h SetLensUndistortion), far cheaper per frame; kAuto (default)
  /// takes kPoints when the lens changes the image's local scale by at most
  /// kPointsMaxScaleChange over the frame (camera/lens.h MaxLensScaleChange), else kFrames
  /// (fisheye rims). The mosaic always remaps its frames. Measured in docs/lenses.md.
  UndistortMode undistort = UndistortMode::kAuto;
  /// Lens self-calibration pre-pass (pipeline/lens_prepass.h, docs/lenses.md "Self-calibration"):
  /// kAuto (default) estimates a one-parameter radial lens (correspondence/lens_estimation.h)
  /// from a few frame pairs spread over the flight, read by a second frame source, when no
  /// calibration file and no k1..k3, p1, p2 are given and the input can be re-read (photo
  /// folder, video file; a live source is skipped with a note); a significant estimate becomes
  /// the run's lens as a calibration file would (undistort applies) and is written to
  /// lens_estimate.yaml. kOff: never (the `--paper` preset).
  LensEstimationMode lens_estimation = LensEstimationMode::kAuto;
  /// Illumination factor k in (0, 1] (the paper's f_k = k f, Fig. 4-6): every frame's brightness
  /// is multiplied by k (ScaleBrightness) after undistortion and before SURF, to study how the
  /// odometry holds in dim light. Default 1 (frames as read).
  double illumination_k = 1.0;
  /// Pixel budget of a frame, megapixels: larger frames are reduced to it before undistortion and
  /// SURF (pipeline/preprocess.h FrameReducer; the focal length scales with them, positions stay
  /// in metres, transforms.csv in full-frame pixels), so one frame's time and memory are bounded
  /// whatever the camera. 0 = never reduce. Default 24: above every common drone frame (4K video
  /// 8.3 MP, 20 MP 1-inch sensors), which run as read; BENCHMARKS.md has the time and memory of a
  /// frame against its size.
  double max_megapixels = 24.0;
  /// Detection budget of video and live frames, megapixels: larger frames are reduced by the
  /// smallest integer factor that brings them within it (a box filter; pipeline/preprocess.h
  /// FrameReducer), before undistortion and SURF, the focal length scaled by the same factor, so
  /// positions stay in metres and transforms.csv in full-frame pixels. 0 = never. Photo folders
  /// are not reduced by it (max_megapixels alone). Default 2.1: 1080p (2.07 MP) and smaller
  /// frames run as read, 4K video is detected at 1920x1080 (twice the ground sampling distance),
  /// which keeps 4K in real time on 2 cores at a track error within 5 % of full resolution
  /// (BENCHMARKS.md, "4K video").
  double detect_megapixels = 2.1;
  /// No progress bar, no configuration dump: errors, warnings (on stderr) and the final table.
  bool quiet = false;
  /// A run owns its output folder: `aerovo run` refuses a folder that is not empty unless
  /// force, which first removes aerovo's own files from it (outputs/run_folder.h; foreign files are
  /// kept). Default false. (The library's RunFlight does not check; the CLI does.)
  bool force = false;
  /// MAVLink link to a flight controller (docs/autopilot.md; mavlink/transport.h):
  /// udp:HOST:PORT, udpin:HOST:PORT or serial:DEVICE:BAUD. Empty (default): none.
  std::string mavlink;
  /// The vision message sent per processed frame. Default ODOMETRY (#331): the one both PX4 and
  /// ArduPilot (4.1+) read with velocity, covariance, reset counter and quality.
  mavlink::VisionMessageKind mavlink_message = mavlink::VisionMessageKind::kOdometry;
  /// Our MAVLink system id: the vehicle's (a companion computer shares its autopilot's; 1 is
  /// the default of PX4 and ArduPilot). The component id is 197 (VISUAL_INERTIAL_ODOMETRY).
  int mavlink_sysid = 1;
  /// Clock of the timestamps: boot (default: CLOCK_MONOTONIC, time since the companion booted,
  /// which the autopilot maps to its own with TIMESYNC) or unix.
  mavlink::TimestampClock mavlink_time = mavlink::TimestampClock::kBoot;
  /// udpin/serial: an autopilot sample (height, attitude) is used for a frame when it arrived
  /// within this many seconds of the frame's capture. Default 0.25 s: rangefinders and ATTITUDE
  /// stream at 10-50 Hz, and a 0.25 s old height is off by < 1 m at a 3 m/s climb.
  double mavlink_match_s = 0.25;
  /// udpin/serial without --altitude: the first frame waits up to this many seconds for the
  /// autopilot's first height. Default 5 s (a stream starts within a second or two).
  double mavlink_wait_s = 5.0;
  /// MAVLink 2 signing key file (mavlink/signing.h; docs/autopilot.md, "Message signing"): 64
  /// hexadecimal digits, mode 600. With it every packet sent is signed and only packets of the
  /// autopilot signed with the same key, timestamps moving forward, are used (the others are
  /// counted in summary.json). Empty (default): unsigned, every valid packet used. Like the
  /// other mavlink_* options, unused without mavlink.
  std::string mavlink_key;
  /// With mavlink_key: the file the signing timestamp is kept in across runs (mavlink/signing.h
  /// ReadSigningTimestamp: read at the start, the first timestamp after it; written every 10 s
  /// and at the end). Empty (default): the key file's name with ".timestamp" appended; "none":
  /// not kept (each run starts from the clock).
  std::string mavlink_key_timestamp;
  /// Also send each frame's geo-referenced position as GPS_INPUT (#232), for ArduPilot to take
  /// as a GPS receiver (GPS1_TYPE 14; mavlink/gps_input.h, docs/autopilot.md "GPS_INPUT"), beside
  /// the vision message. Default false.
  bool mavlink_gps_input = false;
  /// GPS_INPUT: a 3D fix only while the position's standard deviation (its horiz_accuracy) is
  /// at most this, m; else "no fix", which ArduPilot does not use. Default 10 m: twice EKF3's
  /// 5 m alignment limit, a position still worth more than dead reckoning.
  double mavlink_gps_input_max_sigma_m = 10.0;
  /// GPS_INPUT: the odometry's drift as a fraction of the distance flown from the first frame
  /// (the track the geo-reference anchors) or from the last fix against a map fused into the
  /// track (map_fix.apply), added to the position's standard deviation (the
  /// step model alone does not see drift). Default 0.01 (1 %: aerovo's end-point errors on real flights are 0.4-1 % of the
  /// distance, BENCHMARKS.md).
  double mavlink_gps_input_drift = 0.01;
  /// GPS_INPUT.gps_id: the ArduPilot GPS instance that takes it, 0 = the first (GPS1_TYPE 14);
  /// 1 with a real receiver as the first and aerovo as the second (GPS2_TYPE 14).
  int mavlink_gps_input_id = 0;
  /// The pose stream: one JSON object per frame (pipeline/run_steps.h, "The pose stream") written
  /// to this file as soon as the frame is done, flushed; "-" = stdout, and then `aerovo run`
  /// writes nothing else there (configuration, progress, warnings, summary: stderr). Empty
  /// (default): none.
  std::string poses_jsonl;
  /// Frames decoded ahead on a reader thread (frames/prefetch_source.h), so that decoding overlaps
  /// the processing; 0 = decode on the processing thread. A live source (camera, stream) keeps
  /// only the newest frame whatever the value (older ones are dropped, counted: latency stays
  /// bounded); files lose nothing. Default 2: one frame being decoded while one waits.
  int frame_queue = 2;
  /// Telemetry time at the video's time 0, seconds: a frame at video time t takes the fix of
  /// telemetry time t + telemetry_offset_s; non-zero, a telemetry with frame indices (DJI SRT
  /// FrameCnt) is matched by time too (the SRT's time is the video's). Default 0.
  double telemetry_offset_s = 0.0;
  /// After the run, the offset between the telemetry and the video is estimated from the motion
  /// (VO against GPS speed, telemetry/clock.h EstimateTelemetryOffset) and reported; with this
  /// switch the run is then repeated with the estimate added to telemetry_offset_s when it
  /// differs from it by more than 0.2 s and the estimate is clear. Default false (reported only).
  bool telemetry_auto_offset = false;
  /// Camera attitude (docs/attitude.md): kAuto (default) maps each frame's keypoints to a
  /// virtual nadir camera (odometry/attitude.h) when the telemetry gives the camera's attitude:
  /// a gimbal's pitch and roll (DJI XMP GimbalPitchDegree/GimbalRollDegree, SRT gb_pitch/gb_roll,
  /// CSV gimbal_pitch/gimbal_roll; -90 = nadir), else the aircraft's (XMP Flight*Degree, CSV
  /// pitch/roll, MAVLink ATTITUDE over udpin/serial) for a camera fixed under it.
  AttitudeMode attitude = AttitudeMode::kAuto;
  /// A camera fixed to the airframe (attitude from the aircraft's angles): its tilt forward of
  /// nadir when the aircraft is level, degrees (> 0 = towards the image top). Default 0 (nadir).
  double camera_mount_pitch_deg = 0.0;
  /// Camera tilt self-calibration (odometry/attitude_estimation.h, docs/attitude.md "Estimated
  /// from the flight"): kAuto (default) estimates one roll and pitch for the whole flight from
  /// the frame pairs of the self-calibration pre-pass (pipeline/lens_prepass.h) when attitude is
  /// auto, no camera_mount_pitch_deg is given, the first frame's telemetry has no gimbal or
  /// aircraft angles, no autopilot link gives ATTITUDE and the input is a photo folder; a
  /// significant estimate is every frame's camera attitude (source "estimated"). kOff: never
  /// (the `--paper` preset).
  AttitudeEstimationMode attitude_estimation = AttitudeEstimationMode::kAuto;
  /// A camera attitude less than this far from nadir is taken as nadir (no correction), degrees.
  /// Default 0.5 (our choice): below a consumer gimbal's and IMU's own attitude accuracy; DJI
  /// nadir photos report -89.9 (turin-p4m), which stay exactly as without attitude.
  double attitude_min_deg = 0.5;
  /// Warn when the telemetry puts the camera more than this far from nadir and the run does not
  /// correct for it (attitude off), degrees. Default 10 (a 10 deg tilt moves the image centre's
  /// ground point 18 % of the height away from the aircraft).
  double attitude_warn_deg = 10.0;
  /// Altitude of the ground flown over above sea level, m (NaN = unknown, the default): turns
  /// a telemetry altitude above sea level (GPS altitude, SRT abs_alt) into a height above
  /// ground when there is no relative altitude.
  double ground_elevation_m = std::numeric_limits<double>::quiet_NaN();
  /// Height of the take-off point above the ground flown over, m (e.g. launched from a roof
  /// 12 m above the field: 12): added to the telemetry's relative altitude (height above the
  /// take-off point, DJI RelativeAltitude / SRT rel_alt). Default 0 (take-off at ground level).
  double takeoff_height_agl_m = 0.0;
  /// Plausibility of the GPS fixes (odometry/gps_check.h): rejected fixes steer neither the
  /// geo-referencing nor the comparison with GPS; flagged in frames.csv (gps_flag) and listed
  /// in summary.json (gps_rejected).
  GpsCheckOptions gps_check;
  /// GPS denial, seconds after the first frame processed (its Frame::time_s): from the first
  /// frame at or after that time on, the telemetry's horizontal positions (latitude, longitude)
  /// are withheld from the run (ReadFrame, pipeline/frame_loop.cc): neither the geo-referencing
  /// (fixed then from the fixes before, odometry/georef.h FixWithAvailable), the GPS check, the
  /// heights' plausibility nor the telemetry clock's estimate sees them; they are kept only for
  /// the comparison with GPS (frames.csv gps_* with gps_flag "withheld", summary.json
  /// "gps_denied": the error against them over time and per km). The altitudes and angles stay
  /// (barometer, compass, gimbal). 0 = from the start (the track is then not geo-referenced);
  /// negative (default -1) = never.
  double gps_denied_after_s = -1.0;
  /// The reference maps (docs/map.md; map/reference_map.h): any geo-referenced rasters GDAL
  /// opens, in the order of preference (the first with data at a place is read there; a window
  /// it covers in part is filled from the next ones). Opened and checked before the frames (an
  /// InputError naming the map that is missing, corrupt, has no CRS or geotransform; naming them
  /// all when together they cover none of the telemetry's positions the run may use: those
  /// before gps_denied_after_s); after the run, their cover of the geo-referenced track
  /// (summary.json "map", a warning when partial); the frames are matched against it for
  /// absolute fixes (map_fix below; pipeline/map_fixer.h), recorded and compared with GPS
  /// (map_fixes.csv, summary.json "map_fixes"), and with map_fix.apply fused into the pose
  /// graph (stage_map_fix.cc). Empty = none.
  std::vector<std::string> map;
  /// The fixes against `map` (keys map_fix.*; odometry/map_match.h). Unused without a map.
  MapMatchOptions map_fix;
  /// The sensor's static pattern (vignetting, fixed-pattern noise) estimated from the flight and
  /// removed before the reduction and SURF when significant (features/flat_field.h; the stage
  /// pipeline/stage_flat_field.cc): a photo folder's median of photo_samples photos spread over
  /// the flight, a running mean for video and live frames; summary.json "flat_field".
  FlatFieldOptions flat_field;
  /// The odometry and its stages (keys surf.*, match.*, ransac.*, clustered.*, correspondence.*,
  /// odometry.*); defaults are OdometryOptions' (visual_odometry.h). The run sets its focal_px and
  /// default_height_m from the camera and height it resolves (focal_px, hfov_deg, altitude_m
  /// above).
  OdometryOptions odometry;
  /// The offline whole-flight optimisation after the last frame (keys backend.*;
  /// odometry/flight_graph.h, docs/backend.md): vo_optimized.* and summary.json "optimized".
  BackendOptions backend;
};

/// Throws InvalidArgument naming the bad key ("run configuration: ransac.max_distance_px must be
/// > 0, got -1"): the schema's ranges, then the rules between fields.
void Validate(const RunConfig& config);
/// The option schema: the run's own keys (flat, as before the stage keys existed: report/mosaic.cc
/// reads step, start_s, end_s, k1..k3, illumination_k and input from config.json), then the
/// odometry's groups.
// clang-format off
template <class V>
void VisitFields(RunConfig& c, V& v) {
  using namespace options;
  v.Field(c.input, "input", "Video file, image folder (telemetry from EXIF/XMP), camera index, /dev/videoN or URL", Any().Flags("input"));
  v.Field(c.telemetry, "telemetry", "Telemetry file: DJI .srt, .gpx, .csv, an ArduPilot DataFlash log (.bin, .log), a PX4 ULog (.ulg), a MAVLink telemetry log (.tlog) or a video whose subtitle track holds DJI captions; empty: a video's .SRT of the same name beside it, else its own subtitle track, a photo folder's EXIF/XMP; none: no telemetry", Any());
  v.Field(c.lenient_telemetry, "lenient_telemetry", "Skip malformed telemetry records (counted in the warnings) instead of stopping", Any().Switch());
  v.Field(c.truth, "truth", "Ground truth to compare with beside GPS: TUM (.tum/.txt) or a track with positions (.csv, .gpx, .srt)", Any());
  v.Field(c.out, "out", "Output folder", Any().Flags("-o"));
  v.Field(c.step, "step", "Process every k-th frame", Interval(1, 1000000));
  v.Field(c.start_s, "start_s", "Start time in the source, s", AtLeast(0));
  v.Field(c.end_s, "end_s", "End time in the source, s (< 0: to the end)", Any());
  v.Field(c.max_frames, "max_frames", "Stop after N frames (0 = all)", Interval(0, 1000000000));
  v.Field(c.realtime, "realtime", "Files: deliver each frame at its own time in the stream, as a camera would (bench replays against an autopilot)", Any().Switch());
  v.Field(c.heading, "heading", "VO heading in ENU: auto, yaw (telemetry) or gps (first GPS segment)", Any());
  v.Field(c.altitude_m, "altitude_m", "Height above ground, m (overrides telemetry; 0 = from telemetry)", Interval(0, 1e5).Flags("--altitude"));
  v.Field(c.focal_px, "focal_px", "Focal length in pixels (0 = from hfov_deg, EXIF or telemetry)", Interval(0, 1e6));
  v.Field(c.hfov_deg, "hfov_deg", "Horizontal field of view, deg (used when focal_px is 0)", Interval(0, 180, false, true));
  v.Field(c.photo_gap_s, "photo_gap_s", "Photo folders: a capture-time gap longer than this, s, or another camera starts a new flight (0 = no gap check)", AtLeast(0).Finite());
  v.Field(c.photo_flight, "photo_flight", "Photo folders with several flights: 0 = refuse, K = flight K alone, -1 = chain all", Interval(-1, 1000000));
  v.Field(c.photo_band, "photo_band", "Photo folders of a multi-camera payload (photos naming their band or camera: XMP Camera:BandName, DJI drone-dji:ImageSource): the one read, e.g. NIR, thermal (empty = wide, else visible, RGB, green, blue, else the first); WxH (640x512) reads the photos of one size of a folder whose photos name none", Any());
  v.Field(c.video_decoder, "video_decoder", "Video decoder: auto (= ffmpeg), ffmpeg (FFmpeg's libraries, grey from the luma plane, every frame's size checked) or opencv (cv::VideoCapture)", Any());
  v.Field(c.video_threads, "video_threads", "Video decoder threads (ffmpeg decoder; 0 = one per core): 2 leaves the other cores to the odometry", Interval(0, 64));
  v.Field(c.sensor_aspect, "sensor_aspect", "Sensor full-frame aspect (long/short) for a photo's EXIF 35 mm equivalent; 0 = camera model, 4:3 for photos wider than 1.7:1, else the photo's", Interval(0, 4));
  v.Field(c.k1, "k1", "Lens distortion k1 (OpenCV model; 0 = none)", Finite());
  v.Field(c.k2, "k2", "Lens distortion k2", Finite());
  v.Field(c.p1, "p1", "Lens distortion p1 (tangential)", Finite());
  v.Field(c.p2, "p2", "Lens distortion p2 (tangential)", Finite());
  v.Field(c.k3, "k3", "Lens distortion k3", Finite());
  v.Field(c.calibration, "calibration", "Camera calibration file: OpenCV YAML/XML, OpenDroneMap cameras.json or COLMAP cameras.txt (pinhole or fisheye; wins over focal_px, hfov_deg, EXIF)", Any());
  v.Field(c.undistort, "undistort", "Lens undistortion: frames (remap each frame), points (undistort the SURF keypoints) or auto (points when the lens's local scale change over the frame is at most 35 %)", Any());
  v.Field(c.lens_estimation, "lens_estimation", "Lens self-calibration: auto (without a calibration file or k1..k3, estimate a radial lens from a few frame pairs of the flight and apply it when significant; lens_estimate.yaml) or off", Any());
  v.Field(c.illumination_k, "illumination_k", "Illumination factor k: every frame's brightness times k before SURF (the paper's f_k = k f)", Interval(0, 1, true, false));
  v.Field(c.max_megapixels, "max_megapixels", "Frames above this many megapixels are reduced to it before SURF (focal length scaled with them; 0 = never)", AtLeast(0).Finite());
  v.Field(c.detect_megapixels, "detect_megapixels", "Video and live frames above this many megapixels are reduced by the smallest integer factor that fits (box filter) before SURF, focal length scaled with them (0 = never; photo folders: max_megapixels only)", AtLeast(0).Finite());
  v.Field(c.quiet, "quiet", "No progress bar or configuration dump (warnings still go to stderr)", Any().Switch().Flags("-q"));
  v.Field(c.force, "force", "Run into a non-empty output folder: first remove aerovo's own files from it (other files are kept)", Any().Switch());
  v.Field(c.mavlink, "mavlink", "MAVLink link to an autopilot: udp:HOST:PORT, udpin:HOST:PORT or serial:DEVICE:BAUD (docs/autopilot.md)", Any());
  v.Field(c.mavlink_message, "mavlink_message", "Vision message sent per frame", Any());
  v.Field(c.mavlink_sysid, "mavlink_sysid", "MAVLink system id (the vehicle's)", Interval(1, 255));
  v.Field(c.mavlink_time, "mavlink_time", "Clock of the MAVLink timestamps: boot (since boot) or unix", Any());
  v.Field(c.mavlink_match_s, "mavlink_match_s", "Largest time between a frame and the autopilot sample used for it, s", GreaterThan(0).Finite());
  v.Field(c.mavlink_wait_s, "mavlink_wait_s", "udpin/serial: wait this long for the autopilot's first height, s", AtLeast(0).Finite());
  v.Field(c.mavlink_key, "mavlink_key", "MAVLink 2 signing key file (64 hex digits, mode 600): sign what is sent, use only packets signed with it (docs/autopilot.md)", Any());
  v.Field(c.mavlink_key_timestamp, "mavlink_key_timestamp", "File the signing timestamp is kept in across runs ('' = the key file + .timestamp, 'none' = not kept)", Any());
  v.Field(c.mavlink_gps_input, "mavlink_gps_input", "Also send each geo-referenced frame's position as GPS_INPUT (#232) for ArduPilot's GPS1_TYPE 14 (docs/autopilot.md)", Any().Switch());
  v.Field(c.mavlink_gps_input_max_sigma_m, "mavlink_gps_input_max_sigma_m", "GPS_INPUT: 3D fix only while the position's standard deviation is at most this, m", GreaterThan(0).Finite());
  v.Field(c.mavlink_gps_input_drift, "mavlink_gps_input_drift", "GPS_INPUT: odometry drift as a fraction of the distance flown from the first frame (or the last map fix fused), added to the position's standard deviation", Interval(0, 1));
  v.Field(c.mavlink_gps_input_id, "mavlink_gps_input_id", "GPS_INPUT: gps_id, the autopilot's GPS instance that takes it (0 = the first)", Interval(0, 255));
  v.Field(c.poses_jsonl, "poses_jsonl", "Pose stream: one JSON object per frame, written as it is done ('-' = stdout, then everything else goes to stderr)", Any());
  v.Field(c.frame_queue, "frame_queue", "Frames decoded ahead on a reader thread (0 = none); a live source keeps only the newest, dropping older ones", Interval(0, 64));
  v.Field(c.telemetry_offset_s, "telemetry_offset_s", "Telemetry time at video time 0, s (shifts every fix)", Interval(-1e6, 1e6));
  v.Field(c.telemetry_auto_offset, "telemetry_auto_offset", "Estimate the telemetry-video offset from the motion and re-run with it", Any().Switch());
  v.Field(c.attitude, "attitude", "Camera attitude correction: auto (the telemetry's gimbal or aircraft pitch/roll when present) or off (nadir)", Any());
  v.Field(c.camera_mount_pitch_deg, "camera_mount_pitch_deg", "Camera fixed to the airframe: its tilt forward of nadir with the aircraft level, deg", Interval(-45, 45));
  v.Field(c.attitude_estimation, "attitude_estimation", "Camera tilt self-calibration: auto (a photo folder with nothing giving the camera's attitude: estimate one roll and pitch from a few frame pairs of the flight and apply it when significant) or off", Any());
  v.Field(c.attitude_min_deg, "attitude_min_deg", "A camera attitude closer to nadir than this is taken as nadir, deg", Interval(0, 45));
  v.Field(c.attitude_warn_deg, "attitude_warn_deg", "Warn when the telemetry's camera is this far from nadir and attitude is off, deg", Interval(0, 90));
  v.Field(c.ground_elevation_m, "ground_elevation_m", "Ground altitude above sea level, m, for telemetry with only an altitude above sea level (nan = unknown)", Any());
  v.Field(c.takeoff_height_agl_m, "takeoff_height_agl_m", "Take-off point's height above the ground flown over, m (added to the relative altitude)", Interval(-1e4, 1e4));
  v.Field(c.map, "map", "Reference map (GeoTIFF/COG, VRT, MBTiles; docs/map.md); several in the order of preference (--map recent.tif --map older.tif): checked against the flight, its cover of the track reported, the frames matched against it for absolute fixes (map_fixes.csv; fused into the track with --map-fix-apply)", Any());
  v.Field(c.gps_denied_after_s, "gps_denied_after_s", "Withhold the telemetry's positions from this many seconds after the first frame on (0 = from the start, negative = never): kept only for the comparison with GPS", Interval(-1e9, 1e9));
  v.Group("gps_check", c.gps_check);
  v.Group("flat_field", c.flat_field);
  v.Group("odometry", c.odometry);
  v.Group("backend", c.backend);
  v.Group("map_fix", c.map_fix);
}
// clang-format on
/// The paper's exact pipeline (Ivanov & Muzychuk 2023; `aerovo run --paper`, also for
/// `aerovo experiment`): RunConfig's defaults with surf.adaptive = false (MATLAB
/// detectSURFFeatures' fixed MetricThreshold 1000), correspondence.guided_matching = false (every
/// frame matched exhaustively, as matchFeatures), clustered.refine = false (the clustered
/// RANSAC's best cell fit as it is), attitude = off (the paper's nadir camera),
/// lens_estimation = off and flat_field.mode = off. Options given after it (flags, config file) still win.
RunConfig PaperRunConfig();
/// Sets the paper preset's options (those PaperRunConfig changes) in `config`, leaving the rest.
void ApplyPaperPreset(RunConfig& config);
/// The presets in one table (run_config.cc), for docs/options.md: name, what it sets.
struct RunPreset {
  const char* name;
  const char* doc;
  std::vector<std::pair<const char*, const char*>> sets;  ///< key, value as written in docs.
};
const std::vector<RunPreset>& RunPresets();
/// A flat key that sets several options at once (`threads`); giving it and one of its
/// keys with different values is an error naming both.
struct RunShorthand {
  const char* name;
  const char* doc;
  std::vector<const char*> keys;
};
/// The shorthands, in one table (run_config.cc).
const std::vector<RunShorthand>& RunShorthands();
/// The configuration as JSON: the canonical keys of the schema (no aliases, no shorthands).
nlohmann::json ToJson(const RunConfig& config);
/// `base` with the keys present in `json` replaced: canonical keys, their legacy aliases (mode,
/// model, scale, guided, matcher, refine, min_inliers, surf_threshold, max_keypoints, seed, polish)
/// and the shorthands; a nested object {"ransac": {"seed": 2}} reads as "ransac.seed". "resolved"
/// (what a run wrote in its config.json) must be an object and is ignored. Unknown keys, wrong
/// types and two names of one option with different values throw InvalidArgument naming the key
/// (and `source`, e.g. the config file path).
RunConfig RunConfigFromJson(const nlohmann::json& json, RunConfig base,
                            const std::string& source = "config");
/// Every option as a Markdown table (key, flag, type, default, range, doc) and the shorthands:
/// the text of docs/options.md (`aerovo run --list-options`).
std::string RunOptionsMarkdown();
/// Syntax of a run configuration file.
enum class RunConfigFormat { kJson, kYaml };
/// Parses the text of a config file (`source` names it in messages): JSON, or YAML (a flat
/// mapping `key: value` with the same keys; parsed with libyaml), then RunConfigFromJson.
/// InputError names the source and the parse error (with its line for YAML); InvalidArgument
/// names an unknown key or a value of the wrong type or out of the field's range. This is the
/// entry point the config fuzz targets drive (fuzz/).
RunConfig ParseRunConfig(std::string_view text, RunConfigFormat format, RunConfig base,
                         const std::string& source = "config");
/// Reads a config file: YAML for a .yaml/.yml extension, else JSON (ParseRunConfig).
RunConfig LoadRunConfig(const std::filesystem::path& path, RunConfig base);

}  // namespace aerovo
