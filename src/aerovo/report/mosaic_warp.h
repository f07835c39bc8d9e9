// The frame compositing shared by the mosaics of a run (report/mosaic.h: mosaic.jpg in the
// first frame's pixels; report/geo_mosaic.h: the north-up geo-referenced mosaics): the run's
// input is re-read once and every frame warped onto each target canvas by one affine
// canvas_px_from_first_px. Internal to the report module (OpenCV types).
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "aerovo/report/mosaic.h"
#include "aerovo/report/run_reader.h"

namespace aerovo {

/// A canvas the frames are warped onto.
struct MosaicWarpTarget {
  /// canvas pixel (x right, y down, pixel centres at integers) from first-frame pixel.
  cv::Matx23d canvas_from_first;
  cv::Mat bgr;       ///< CV_8UC3, allocated and filled (background) by the caller.
  cv::Mat coverage;  ///< CV_8UC1 of bgr's size; set to 255 where a frame was drawn.
};

struct MosaicWarpOutcome {
  bool ok = false;
  std::string note;  ///< Why nothing was drawn ("the run has no transforms.csv ..."), when !ok.
  int frames_used = 0;
  int every_nth = 1;
  int n_transforms = 0;
};

/// The frame size of config.json's "resolved" block; false when unknown.
bool MosaicFrameSize(const RunData& run, int* width_px, int* height_px);

/// Checks the run can be re-read (transforms, frame size, input file or folder); returns an
/// empty string when it can, else the reason (without a "no mosaic:" prefix).
std::string MosaicInputProblem(const RunData& run);

/// Re-reads the run's frames (every n-th so that at most options.max_frames are used; the
/// run's step, time window, undistortion and illumination) and warps each onto every target
/// (later frames on top). Never throws for an unreadable input: ok = false with a note.
MosaicWarpOutcome WarpRunFrames(const RunData& run, const MosaicOptions& options,
                                std::vector<MosaicWarpTarget>& targets);

}  // namespace aerovo
