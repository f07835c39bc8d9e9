// The report's colours, defined once: one colour per track in every figure (plot.h), on the
// mosaics (mosaic.h MosaicTrack::color_rgb) and on the interactive map of report.html, so that a
// reader who learns "GPS is blue" in one figure reads every other one the same way. Track
// colours are from Okabe & Ito's colour-blind-safe palette ("Color Universal Design", 2008);
// the other series (counts, stage times, experiment runs) take kSeriesPalette, which leaves the
// track colours out.
#pragma once

#include <cstddef>
#include <string>

namespace aerovo::style {

/// 0xRRGGBB.
using Rgb = unsigned;

inline constexpr Rgb kGps = 0x0072B2;    ///< GPS fixes of the run (blue).
inline constexpr Rgb kVo = 0xD55E00;     ///< The visual-odometry track (vermillion).
inline constexpr Rgb kTruth = 0x009E73;  ///< A ground truth, e.g. the simulator's (bluish green).
/// The VO track under the Sim(2) alignment (a second view of the VO track, drawn dashed).
inline constexpr Rgb kVoSim2 = 0xCC79A7;  // reddish purple
/// The offline optimisation's track (vo_optimized.*, docs/backend.md) beside the causal VO track
/// (dark purple: not in Okabe & Ito's eight, whose remaining yellow is unreadable on white).
inline constexpr Rgb kVoOptimized = 0x5E3C99;
/// Frames bridged with the previous motion (no image measurement), marked on tracks (orange).
inline constexpr Rgb kBridged = 0xE69F00;
/// Start of a track (a mark), and a whole-frame total among stage times.
inline constexpr Rgb kStart = 0x000000;
/// Fixes against a reference map (docs/map.md): fused into the track, recorded (a fix not
/// fused), rejected by a gate (the map fix's, or the pose graph's).
inline constexpr Rgb kMapFixFused = 0x1B7837;   // dark green
inline constexpr Rgb kMapFixRecorded = 0x35978F;  // teal
inline constexpr Rgb kMapFixGated = 0xB2182B;   // dark red

/// Colours of series that are not tracks, in order: no track colour among them.
/// Black comes fifth: a figure of four stages draws their total in black (kStart).
inline constexpr const char* kSeriesPalette[] = {"#56B4E9", "#7B3294", "#999999", "#B8A000",
                                                 "#000000", "#8C510A", "#01665E", "#E7298A"};
inline constexpr std::size_t kSeriesPaletteSize =
    sizeof(kSeriesPalette) / sizeof(kSeriesPalette[0]);

/// "#rrggbb" of `rgb` (upper-case hex digits), for gnuplot, HTML and SVG.
inline std::string Hex(Rgb rgb) {
  static const char* const kDigits = "0123456789ABCDEF";
  std::string s = "#000000";
  for (int i = 0; i < 6; ++i) s[static_cast<std::size_t>(6 - i)] = kDigits[(rgb >> (4 * i)) & 0xF];
  return s;
}

}  // namespace aerovo::style
