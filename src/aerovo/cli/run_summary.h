// The end of `aerovo run` on the terminal: a one-line answer a pilot understands (frames
// tracked, distance flown, where the track ended against GPS, metres and per cent), then the
// details (frames, camera, the SE(2)/Sim(2) comparison tables, stage times, the files written),
// every line within 80 columns. One function taking the stream, so the caller chooses stdout or
// stderr (stderr when stdout carries the pose stream).
#pragma once

#include <ostream>
#include <string>

#include "aerovo/pipeline/runner.h"

namespace aerovo::cli {

/// The headline: "Tracked 170 of 172 frames over 1558 m; the track ends 24.6 m (1.58 %) from
/// GPS." The end error is the unaligned one (the track as geo-referenced during the flight, at
/// the last frame with a fix); the distance is GPS's path length, else the VO's. No newline.
std::string RunHeadline(const RunSummary& summary);

/// `folder`'s file names (and sub-folders, with a '/'), sorted, as lines of at most `width`
/// columns after an indent of two spaces.
std::string WrappedFileList(const std::string& folder, int width = 80);

/// Prints the headline, a blank line, then the details, to `out`.
void PrintRunSummary(std::ostream& out, const RunSummary& summary);

}  // namespace aerovo::cli
