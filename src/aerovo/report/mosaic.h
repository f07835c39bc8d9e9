// A mosaic of a flight: frames re-read from the run's input, warped by the estimated transforms
// (transforms.csv: first_px_from_frame; transforms_optimized.csv instead when the run ran the
// offline optimisation, docs/backend.md) into the first frame's pixel frame, downscaled to fit,
// with tracks (VO, GPS) drawn on it. File I/O (reads frames, writes an image): report module.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "aerovo/report/run_reader.h"

namespace aerovo {

/// Options of BuildMosaic. Defaults keep a 200-frame run under a couple of seconds.
struct MosaicOptions {
  /// The longer side of the mosaic image, pixels (the whole flight is scaled to fit). 2000.
  int max_size_px = 2000;
  /// At most this many frames are warped (every n-th processed frame; the last one on top).
  int max_frames = 60;
  int jpeg_quality = 88;  ///< 1..100, for a .jpg output.
  /// Place the frames by the offline optimisation's poses (transforms_optimized.csv) when the
  /// run has them; false, or a run without them: by the causal ones (transforms.csv).
  bool optimized = true;
};

/// Throws InvalidArgument naming the field.
void Validate(const MosaicOptions& options);

/// A polyline to draw, in the first frame's pixels (x right, y down).
struct MosaicTrack {
  std::string name;  ///< Legend text.
  std::vector<Eigen::Vector2d> points_px;
  /// Colour as 0xRRGGBB.
  unsigned color_rgb = 0xD55E00;
  /// Line width in pixels per 1000 px of mosaic (so 2000 px mosaics get twice as wide lines),
  /// at least 2 px.
  int line_width_px = 3;
};

struct MosaicResult {
  bool written = false;             ///< false: skipped, see note.
  std::filesystem::path file;       ///< The image written.
  std::string note;                 ///< Why it was skipped, or what it shows.
  int frames_used = 0;              ///< Frames warped.
  int every_nth = 1;                ///< Every n-th processed frame was used.
  int width_px = 0, height_px = 0;  ///< Mosaic size.
  double scale = 1.0;               ///< Mosaic pixels per first-frame pixel.
  bool optimized = false;           ///< Frames placed by transforms_optimized.csv.
};

/// The frame placements (first_px_from_frame rows) the mosaics warp with:
/// run.transforms_optimized when `options.optimized` and the run has them (one per row of
/// run.transforms), else run.transforms.
const std::vector<FrameTransformRow>& MosaicPlacements(const RunData& run,
                                                       const MosaicOptions& options);

/// Builds the mosaic of `run` (needs transforms.csv and config.json with input, step, start_s,
/// end_s and resolved frame size) into `out_file` (.jpg or .png). Frames are re-read with
/// frames/frame_source.h. Returns written = false with a note, not an error, when the run has no
/// transforms, the input is not a file or folder any more (or a live source), or cannot be read.
/// Throws InputError only when `out_file` cannot be written.
MosaicResult BuildMosaic(const RunData& run, const std::vector<MosaicTrack>& tracks,
                         const std::filesystem::path& out_file, const MosaicOptions& options = {});

/// Centre of every frame of `run` with a transform, in first-frame pixels (frame order of
/// transforms.csv, or of `rows` when given, e.g. run.transforms_optimized); `frames` receives
/// their frame indices. Needs config.json's resolved frame size; empty when unknown.
/// The homography nadir_from_frame of the run's frames (odometry/attitude.h
/// NadirFromCameraHomography: a pixel of the frame as read, after the lens undistortion, to the
/// pixel of the same ray in the virtual nadir camera whose pixels transforms.csv places, principal
/// point at the frame's centre) of frame `frame` (a source index): the attitude the run applied
/// to it (frames.csv camera_roll_deg, camera_pitch_deg), and the run's focal length (config.json
/// "resolved"."focal_px"); the identity when the run applied none to it. A run folder of an older
/// build, without those columns: the flight's estimate when applied (summary.json
/// "attitude_estimate" with "applied": its roll_deg and pitch_deg) for every frame.
Eigen::Matrix3d MosaicNadirFromFrame(const RunData& run, int width_px, int height_px, int frame);
/// Whether frames.csv of `run` records the camera attitude applied
/// (RunData::records_camera_attitude: its columns are there, whether or not a frame had an
/// attitude).
bool RecordsCameraAttitude(const RunData& run);

std::vector<Eigen::Vector2d> FrameCentresPx(const RunData& run, std::vector<int>* frames = nullptr,
                                            const std::vector<FrameTransformRow>* rows = nullptr);

}  // namespace aerovo
