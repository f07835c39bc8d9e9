// Sources of frames for the odometry: video files (FFmpeg's libraries through
// frames/video_decoder.h, or OpenCV's cv::VideoCapture), image folders and live cameras/streams
// (OpenCV), delivered as 8-bit grey images.
#pragma once

#include <cstdint>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "aerovo/core/image.h"
#include "aerovo/frames/image_file.h"
#include "aerovo/frames/image_metadata.h"
#include "aerovo/frames/video_decoder.h"
#include "aerovo/frames/video_decoder_choice.h"
#include "aerovo/imageio/image_io.h"

namespace aerovo {

/// One frame as delivered by a FrameSource.
struct Frame {
  /// 8-bit grey, full range: videos through VideoDecoder, the decoder's luma plane (the
  /// stream's own colour matrix, frames/video_decoder.h); photos, live sources and videos through
  /// OpenCV, OpenCV's BGR->grey weights 0.299 R + 0.587 G + 0.114 B.
  GrayImage gray;
  cv::Mat color;   ///< BGR 8-bit, only when FrameSourceOptions::keep_color (else empty).
  /// 0-based position in the source: the video frame number, the photo's rank in the ordered
  /// folder, the count of frames read from a live source. With step k, indices go 0, k, 2k...
  int index = -1;
  /// Seconds: video = index / fps (the container's timestamp when fps is unknown); photos =
  /// capture time - the first photo's (or the rank when a photo has no capture time); live =
  /// the frame's own time, from when the source was opened (LiveSource).
  double time_s = 0.0;
  std::string name;  ///< Photo file name, or "<video file name>#<index>", or "live#<index>".
  /// What is wrong with this frame as read, '+'-separated tokens ("" = nothing found). The run
  /// processes a flagged frame, appends the flags to its status in frames.csv and counts it in
  /// summary.json. Tokens:
  ///  - "duplicate": a video, live or photo frame whose decoded pixels are identical (64-bit
  ///    hash) to the previous delivered frame's: a repeated or stale frame, or a photo copied
  ///    under a second name, whose step is a false zero.
  ///  - "truncated": a photo file cut short (a JPEG without its end-of-image marker), decoded by
  ///    libjpeg with the missing part filled in grey.
  std::string flags;
  /// When the frame came out of its source, seconds on the steady clock (SteadySeconds(),
  /// core/timer.h): set by PrefetchSource's reader thread (frames/prefetch_source.h) as the source
  /// delivers it, else by the run's frame loop as Next() returns; NaN when unset. The start of
  /// the capture-to-send latency (for a live source: arrival and decoding, not the exposure).
  double received_s = std::numeric_limits<double>::quiet_NaN();
};

/// Flag tokens of Frame::flags.
inline constexpr const char* kFrameFlagDuplicate = "duplicate";
inline constexpr const char* kFrameFlagTruncated = "truncated";

/// A 64-bit hash of the pixels of `image` (row by row; the same pixels give the same hash).
/// Used to find repeated frames (BENCHMARKS.md has its cost per frame).
std::uint64_t PixelHash(const GrayImage& image);

/// Options of every frame source. Validate() checks them.
struct FrameSourceOptions {
  /// Deliver every k-th frame (k >= 1). The paper processes every k-th video frame; default 1.
  int step = 1;
  /// Frames with time_s < start_time_s are skipped (videos seek there). Default 0.
  double start_time_s = 0.0;
  /// Frames with time_s > end_time_s end the source. Default: no limit.
  double end_time_s = std::numeric_limits<double>::infinity();
  /// Keep the BGR image in Frame::color (costs a copy per frame). Default false.
  bool keep_color = false;
  /// Image folders: files that are not images (by extension) are skipped and counted in
  /// warnings() (true, default) or make the folder an error (false).
  bool skip_non_images = true;
  /// Image folders: a photo taken more than photo_gap_s after the previous one (EXIF capture
  /// times) starts a new flight, and so does a photo from another camera (EXIF make, model or
  /// serial number). 0 = no gap check. Default 600 s: a pause within one flight (a hover, a
  /// mission paused for minutes over the same ground) is not a new flight, two sorties are
  /// further apart (landing, battery change, take-off and climb); gaps over 60 s shorter than
  /// this are chained with a warning naming the two photos.
  double photo_gap_s = 600.0;
  /// Image folders holding more than one flight: 0 refuses the folder (InputError naming the
  /// two photos where flights change, the gap or the cameras, and every flight); K >= 1
  /// delivers flight K only; -1 chains them all as one sequence (before 0.2: silently).
  int photo_flight = 0;
  /// Image folders of a multi-camera payload, one photo per camera at each capture: the camera
  /// whose photos are read, the others skipped. A photo names its camera by its band (XMP
  /// Camera:BandName, ImageMetadata::band_name: multispectral cameras) or DJI's
  /// drone-dji:ImageSource (ImageMetadata::image_source: "WideCamera", "ZoomCamera",
  /// "InfraredCamera" of Zenmuse H20T-class payloads). Compared without case, spaces, '_' and
  /// '-' ("rededge" is "Red edge"; "wide", "zoom", "thermal" name DJI's cameras); "RGB" is also
  /// a multispectral camera's photos that name no band (DJI P4 Multispectral's JPEGs). Empty
  /// (default): the wide camera, else visible, else RGB, else green, else blue, else the
  /// payload's first camera (multispectral: OpenDroneMap's choice of its primary band,
  /// OpenDroneMap/ODM opendm/multispectral.py get_primary_band_name). A camera the folder does not
  /// hold is an InputError listing those it holds. In a folder whose photos name no band or camera,
  /// "WxH" (e.g. 640x512) reads the photos of that size alone: a payload of cameras that do not
  /// name theirs (a Zenmuse XT2's visible and thermal photos), which the size check would refuse.
  std::string photo_band;
  /// Video files: the decoder. Default auto = ffmpeg, our own (it sees every frame's
  /// decoded size, so a resolution change mid-stream is an error; grey from the luma plane,
  /// no BGR); opencv = cv::VideoCapture, the decoder before it (BENCHMARKS.md "Video decoding").
  VideoDecoderChoice video_decoder = VideoDecoderChoice::kAuto;
  /// Video files through the ffmpeg decoder: the codec's threads (frame + slice threading), 0 =
  /// one per core (FFmpeg's choice). Default 2: the decoder runs on PrefetchSource's reader
  /// thread beside the odometry's frame loop on an on-board computer that is busy with the
  /// odometry: two threads let decoding overlap itself without taking every core
  /// as 0 would; frame threading costs no extra CPU per frame (measured: 1, 2 and one per core
  /// within noise, BENCHMARKS.md "Video decoding"), only a frame of latency per thread.
  int video_threads = 2;
};

/// Throws InvalidArgument naming the field: step < 1, start_time_s < 0 or not finite,
/// end_time_s < start_time_s or NaN, video_threads outside [0, 64].
void Validate(const FrameSourceOptions& options);

/// A sequence of frames. Next() fills `frame` and returns true, or returns false at the end.
/// Next() reuses `frame.gray`'s storage when the size matches: to keep a previous frame, pass
/// a different Frame object (or move it away) before the next call.
/// Errors that make the source unusable (cannot open, undecodable photo, size change) throw
/// InputError naming the source and the frame; a video that ends before its header's frame
/// count ends the sequence with a message in warnings().
class FrameSource {
 public:
  virtual ~FrameSource() = default;
  virtual bool Next(Frame& frame) = 0;
  /// What is being read ("video 'flight.mp4' 1920x1080 @ 29.97 fps, 1234 frames").
  virtual std::string Describe() const = 0;
  /// Frames Next() will deliver in total (after step/start/end) if known, else -1.
  virtual int ExpectedFrameCount() const { return -1; }
  /// True for a source whose frames arrive on their own clock whether or not they are taken
  /// (camera, stream): a run then keeps only the newest (PrefetchSource, QueuePolicy::
  /// kDropOldest). False (default) for files, whose every frame waits to be read.
  virtual bool IsLive() const { return false; }
  /// Non-fatal problems met so far (skipped files, early end of stream).
  const std::vector<std::string>& warnings() const { return warnings_; }

 protected:
  std::vector<std::string> warnings_;
};

/// A video file read with our FFmpeg decoder (frames/video_decoder.h; FrameSourceOptions::
/// video_decoder auto or ffmpeg, the default) or with cv::VideoCapture (FFmpeg backend; opencv).
/// Opening throws InputError "cannot open video '<path>': <reason>" for a missing or empty
/// file, a file FFmpeg cannot read (text named .mp4, truncated container) or a video whose
/// first frame cannot be decoded. A video that ends before its header's frame count (a cut
/// file) ends with a warning, and its last decoded frame is dropped: FFmpeg decodes the cut
/// final packet into an incomplete image (the next frame is grabbed ahead to know).
/// Orientation: frames are delivered as stored (sensor orientation), never rotated by the
/// container's rotation metadata (OpenCV's CAP_PROP_ORIENTATION_AUTO is turned off; ours never
/// rotates), the same policy as photos' EXIF orientation: focal length, field of view and heading
/// refer to the sensor's axes. A video with rotation metadata gets a warning saying so
/// (rotation_deg()).
/// Start time: frames before it are decoded and skipped by ours (exact, costs decoding time);
/// OpenCV seeks.
/// Repeated frames: a frame identical to the one delivered before is flagged "duplicate"
/// (Frame::flags); kMaxRepeatedFrames of them in a row after the video has moved mean the
/// decoder is handing back its last good image (a resolution change mid-stream, as in
/// concatenated recordings or MPEG-TS, or a damaged stream): Next() throws InputError naming the
/// video and the frame where the image froze. A change of decoded size throws too (InputError
/// naming the video, the frame and both sizes), and so does a stream whose timestamps go back and
/// then on from there: recordings joined into one file. Our decoder sees every frame's own
/// size, so it catches any resolution change; OpenCV's converts every frame to the first size:
/// a larger later part comes out as copies of the last frame (the repeated-frame error), a
/// smaller one is silently stretched to the first size, caught only when the clock restarts
/// there (known limitation of video_decoder opencv, docs/inputs.md "Frames that are not what the
/// camera saw").
class VideoFileSource : public FrameSource {
 public:
  explicit VideoFileSource(const std::filesystem::path& path,
                           const FrameSourceOptions& options = {});
  bool Next(Frame& frame) override;
  std::string Describe() const override;
  int ExpectedFrameCount() const override;
  double fps() const { return fps_; }
  int frame_count() const { return frame_count_; }  ///< From the container (may be 0/wrong).
  int width() const { return width_; }
  int height() const { return height_; }
  /// The container's rotation metadata, degrees clockwise for display (0, 90, 180, 270; the
  /// stream's display matrix, or CAP_PROP_ORIENTATION_META). Frames are not rotated (see the
  /// class comment).
  int rotation_deg() const { return rotation_deg_; }
  /// Frames delivered flagged "duplicate" so far.
  int duplicate_frames() const { return duplicates_; }
  /// Identical frames in a row (after a change) that make the video an error: 5 repeats = 6
  /// identical frames, 0.2 s at 30 fps. A drone camera's sensor noise makes two real frames
  /// differ in some pixel; a stale decoder repeats one image exactly (measured: the 640x360
  /// half of a 320x240 + 640x360 MPEG-TS came out as 20 copies of the last 320x240 frame).
  static constexpr int kMaxRepeatedFrames = 5;
  /// The decoder in use: kFfmpeg or kOpenCv (auto resolved).
  VideoDecoderChoice decoder() const {
    return decoder_ ? VideoDecoderChoice::kFfmpeg : VideoDecoderChoice::kOpenCv;
  }

 private:
  bool GrabTo(int target_index);  // grabs frames until next_index_ == target_index
  bool GrabOne();                 // decodes the next frame (no conversion)
  double GrabbedTimestampMs() const;  // of the frame last grabbed (NaN: unknown)
  bool RetrieveGrabbed();  // converts the frame last grabbed into gray_/bgr_; sets cur_w_/cur_h_
  void DeliverTo(Frame& frame);  // the retrieved frame into frame.gray/frame.color
  // Decodes the frame `step` after the last delivered one (or takes the look-ahead frame);
  // false at the end of the stream (done_ set, a truncation warning when the header said more).
  bool DecodeNextStep();
  // Grabs the frame after `index` ahead (see Next); false when the stream ends early, before
  // its header's frame count: `index` is then the cut frame and is dropped (done_ set).
  bool LookAhead(int index);

  std::filesystem::path path_;
  FrameSourceOptions options_;
  std::unique_ptr<VideoDecoder> decoder_;  // ours; null: capture_ (opencv)
  imageio::VideoCapture capture_;
  double fps_ = 0.0;
  int frame_count_ = 0;
  int width_ = 0, height_ = 0;
  int cur_w_ = 0, cur_h_ = 0;  // decoded size of the frame in gray_/bgr_
  int next_index_ = 0;  // index of the frame the next grab() returns
  bool first_ = true;
  bool done_ = false;
  bool lookahead_grabbed_ = false;  // frame next_index_ - 1 is grabbed, not yet retrieved
  cv::Mat bgr_;    // opencv: the frame; ffmpeg: its colour when keep_color
  GrayImage gray_;  // ffmpeg: the frame (swapped into Frame::gray)
  int rotation_deg_ = 0;
  std::uint64_t last_hash_ = 0;
  bool have_hash_ = false;
  bool moved_ = false;       // two delivered frames differed
  int repeats_ = 0;          // frames in a row identical to the one before
  int freeze_index_ = -1;    // index of the frame the repeats copy
  int last_index_ = -1;      // index of the last delivered frame
  int duplicates_ = 0;
  // CAP_PROP_POS_MSEC of the frame being delivered, of the look-ahead frame, of the last one
  // delivered (NaN: none yet).
  double current_ts_ms_ = std::numeric_limits<double>::quiet_NaN();
  double lookahead_ts_ms_ = std::numeric_limits<double>::quiet_NaN();
  double last_ts_ms_ = std::numeric_limits<double>::quiet_NaN();
};

/// The photos of a folder (not recursive): .jpg .jpeg .png .tif .tiff, any case.
/// Order: by EXIF capture time (DateTimeOriginal + SubSecTimeOriginal), ties by file name,
/// when every photo has one; otherwise by file name (with a warning). Hidden files (name
/// starting with '.', e.g. macOS "._DJI_0001.JPG") are always skipped and counted; other
/// non-photo files are skipped and counted in warnings() (or throw with skip_non_images =
/// false). Photos of different
/// sizes throw InputError naming the odd photo and both sizes (checked from the headers at
/// opening, and again on decoding). An undecodable photo throws InputError naming it and the
/// problem (empty file, not an image, cut short: frames/image_file.h CheckImageFile, run on every
/// photo at opening). A JPEG cut short that libjpeg still decodes (the missing part grey) is
/// delivered flagged "truncated" (Frame::flags), with a warning naming it printed to stderr at
/// opening (before libjpeg's own unnamed "Premature end of JPEG file") and kept in warnings().
class ImageFolderSource : public FrameSource {
 public:
  explicit ImageFolderSource(const std::filesystem::path& folder,
                             const FrameSourceOptions& options = {});
  bool Next(Frame& frame) override;
  std::string Describe() const override;
  int ExpectedFrameCount() const override;
  /// All photos in delivery order (before step/start/end), with their metadata.
  const std::vector<std::filesystem::path>& paths() const { return paths_; }
  const std::vector<ImageMetadata>& metadata() const { return metadata_; }
  /// time_s of photo i (see Frame::time_s).
  double TimeOf(std::size_t i) const { return times_[i]; }
  /// Photo i of paths() into `frame` as Next() would deliver it (index i), whatever the
  /// position of Next(), which it does not move: random access for a second reader (the lens
  /// self-calibration pre-pass). InvalidArgument for i out of range; InputError as Next().
  void Read(std::size_t i, Frame& frame);
  int skipped_files() const { return skipped_files_; }
  /// Flights found in the folder (FrameSourceOptions::photo_gap_s), >= 1.
  int flight_count() const { return flight_count_; }
  /// The band or camera read when the folder's photos name theirs (FrameSourceOptions::
  /// photo_band), as they name it ("RGB" for a payload's photos that name none); empty when no
  /// photo names one.
  const std::string& band() const { return band_; }

 private:
  std::filesystem::path folder_;
  FrameSourceOptions options_;
  std::vector<std::filesystem::path> paths_;
  std::vector<ImageMetadata> metadata_;
  std::vector<ImageFileCheck> checks_;
  std::vector<double> times_;
  std::size_t next_ = 0;
  int width_ = 0, height_ = 0;
  int skipped_files_ = 0;
  int flight_count_ = 1;
  std::string band_;
  bool have_hash_ = false;       // the last delivered photo's pixel hash (duplicate flag)
  std::uint64_t last_hash_ = 0;
};

/// The own times of a live source's frames (Frame::time_s, LiveSource), seconds: the first
/// frame's arrival, then each frame the source's own time step after the previous one, so that
/// frames buffered at a stream's start and delivered together keep their spacing. A step of the
/// source's own time that does not move forward, is not finite, or runs more than 1 s ahead of
/// the arrivals (a restarted sender, a timestamp wrap) is replaced by the arrival step.
class LiveFrameTimes {
 public:
  /// The time of a frame that arrived at `arrival_s` (seconds, steady clock, any origin) with
  /// the source's own time `stream_ms` (milliseconds, any origin; NaN or a constant when the
  /// source has none). When the arrival step replaces the source's, `unusable` (if not null)
  /// says why; else it is left as it was.
  double Next(double arrival_s, double stream_ms, std::string* unusable);
  /// Frames timed by their arrival step so far (not counting the first frame).
  int arrival_steps() const { return arrival_steps_; }

 private:
  bool have_ = false;
  int arrival_steps_ = 0;
  double last_arrival_s_ = 0.0, last_stream_s_ = 0.0, last_time_s_ = 0.0;
};

/// A camera or stream: a camera index ("0"), a device path ("/dev/video0") or a URL
/// ("rtsp://...", "http://..."). Frames are delivered as they arrive; with step k the k-1
/// frames in between are grabbed and dropped (no decode). time_s is the frame's own time
/// (LiveFrameTimes), from the source's opening: a stream's presentation times or a V4L2
/// camera's capture timestamps (cv::CAP_PROP_POS_MSEC), else arrivals, with a warning the first
/// time a frame is timed by its arrival.
/// Opening throws InputError "cannot open live source '<spec>': ..."; a stream that stops
/// ends the sequence with a warning. A frame identical to the previous one is flagged
/// "duplicate" (Frame::flags): a frozen stream.
class LiveSource : public FrameSource {
 public:
  explicit LiveSource(int camera_index, const FrameSourceOptions& options = {});
  explicit LiveSource(const std::string& device_or_url, const FrameSourceOptions& options = {});
  bool Next(Frame& frame) override;
  std::string Describe() const override;
  bool IsLive() const override { return true; }

 private:
  void Init();
  std::string spec_;
  FrameSourceOptions options_;
  imageio::VideoCapture capture_;
  int next_index_ = 0;
  double t0_ = 0.0;
  bool done_ = false;
  cv::Mat bgr_;
  std::uint64_t last_hash_ = 0;
  bool have_hash_ = false;
  LiveFrameTimes times_;
};

/// Chooses the source from `spec`: an all-digit string -> camera index; "scheme://..." or a
/// path under /dev/ -> LiveSource; an existing directory -> ImageFolderSource; an existing
/// file -> VideoFileSource. Throws InputError when nothing exists at `spec`.
std::unique_ptr<FrameSource> OpenFrameSource(const std::string& spec,
                                             const FrameSourceOptions& options = {});

/// Converts an OpenCV 8-bit image (1, 3 or 4 channels) to a GrayImage (copy).
/// Throws InvalidArgument for other depths/channel counts.
GrayImage ToGrayImage(const cv::Mat& image);
/// The same into `out`, reusing its storage when the size matches (no allocation per frame).
void ToGrayImage(const cv::Mat& image, GrayImage& out);

}  // namespace aerovo
