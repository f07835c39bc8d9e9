// An absolute position fix from one nadir frame matched against a north-up window of a
// geo-referenced map (no I/O: the caller reads the window, e.g. map/reference_map.h
// ReferenceMaps::Window, and hands its pixels here).
//
// Frames:
// - frame pixels: x right, y down, the frame's centre ((w - 1) / 2, (h - 1) / 2) is the camera
//   centre (odometry/pose_chain.h);
// - window pixels: north-up, x east, y south, `m_per_px` per pixel;
// - window ENU: metres east and north of the window's centre pixel ((size - 1) / 2, the
//   MapWindow convention of map/reference_map.h);
// - heading_rad: angle counter-clockwise seen from above from north to the frame's image-up
//   direction (the odometry's heading plus GeoReferencer::rotation_rad, odometry/georef.h).
//
// The frame is warped to the window's ground resolution (scale from its ground sampling
// distance, height / focal_px) and, when the heading is known, rotated north-up (then upright
// SURF, else rotation-invariant SURF); SURF (features/surf.h) on both, the matcher
// (matching/matcher.h; guided around the prior when the heading is known) and the similarity
// RANSAC (estimation/ransac.h) give window_px_from_warped; the fit is checked (inliers, their
// spread over the frame, its scale against 1, its distance from the prior and its rotation
// against the heading) and turned into the frame centre's ENU position and heading with the
// fit's covariance.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>

#include <Eigen/Core>

#include "aerovo/core/image.h"
#include "aerovo/core/options.h"
#include "aerovo/features/keypoint.h"

namespace aerovo {

/// Options of map fixes (keys map_fix.* in a run configuration).
struct MapMatchOptions {
  /// Match every n-th frame against the map (1 = every frame).
  int every_n_frames = 10;
  /// The fixes move the track: each is fused into the pose graph of the online window as an
  /// absolute factor with its covariance, gated against the track (pipeline/stage_map_fix.cc,
  /// odometry/flight_graph.h FlightGraph::AddFix; without backend.online the window runs
  /// "fixes only"). Default false: the fixes are recorded and compared with GPS only.
  bool apply = false;
  /// Ground resolution of the matching, m/px; 0 = automatic: the coarser of the map's own
  /// resolution and the frame's ground sampling distance times frame width / match_width_px.
  double match_m_per_px = 0.0;
  /// Automatic resolution: the frame is brought to about this many pixels across (a frame wider
  /// on the ground is matched coarser: the cost stays bounded whatever the height).
  int match_width_px = 400;
  /// Search radius around the predicted position, metres: the window covers the frame's
  /// footprint plus this, and a fix farther than this from the prediction is rejected (gate).
  double search_radius_m = 60.0;
  /// A fix farther than this from the prediction is rejected (gate), metres; 0 = search_radius_m.
  /// Smaller than the radius: a wider search (a prior that may be far off) with a tighter gate.
  double gate_m = 0.0;
  /// Frame SURF points (adaptive selection, features/surf.h); the map window's target is this
  /// times the ratio of its valid area to the frame's.
  int frame_points = 800;
  /// Most SURF points of the map window.
  int max_map_points = 8000;
  /// The map's SURF points are detected once per tile of a fixed grid and kept for the next
  /// attempts (pipeline/map_tiles.h; local attempts only, not a wide search's windows), the
  /// frame's part of the automatic resolution rounded to steps of 9 % (MapLadderResolution)
  /// so that the tiles serve while the height changes a little. false: every attempt reads its window and
  /// detects its points.
  bool tile_cache = true;
  /// RANSAC inlier threshold at the matching resolution, px.
  double max_distance_px = 2.0;
  /// RANSAC trials (most) and seed: same seed and input, same fix.
  int ransac_trials = 2000;
  std::uint64_t seed = 1;
  /// Fewest inliers of a fix.
  int min_inliers = 12;
  /// Smallest spread of the inliers over the frame: the square root of the smaller eigenvalue
  /// of their positions' covariance over the frame's smaller side (points spread uniformly over
  /// the whole frame: 0.29; along one line: 0).
  double min_spread = 0.06;
  /// Largest error of the fit's scale against the expected one (|log scale| <= log(1 + this)):
  /// a height or focal length this wrong is not a fix.
  double max_scale_error = 0.15;
  /// With a heading: the fit's rotation may differ from it by at most this, degrees (gate).
  double max_heading_error_deg = 15.0;
  /// Smallest robust intensity range (1st to 99th percentile) of the valid map window, and of the
  /// frame, grey levels: below it there is no texture to match.
  double min_contrast = 12.0;
  /// Smallest share of the window the map has data in.
  double min_valid_fraction = 0.2;
  /// Fewest pixels across the frame at the attempt's resolution (the frame's ground width over
  /// the window's m_per_px): a map so coarse that the frame's footprint spans fewer of its
  /// pixels is not matched (status kMapTooCoarse). SURF's first octave alone uses 9-27 px
  /// filters (Bay et al., "SURF: Speeded Up Robust Features", CVIU 110(3), 2008, section 4.1),
  /// so a frame this narrow leaves too few points to fit: on the real flights no attempt under
  /// 99 px gave a fix, some at 106-124 px did (BENCHMARKS.md "Maps coarser than the frames").
  int min_frame_width_px = 96;

  // Lost and found: the wide search (MapMatcher::Search, pipeline/map_fixer.h; docs/map.md).
  /// Consecutive failed attempts (few_inliers, ambiguous, spread, scale, gate) after which the
  /// next attempt is a wide search of search_wide_radius_m; 0 = never (nor at the start).
  int search_after_failures = 3;
  /// The run's first attempt is a wide search too (the prediction not checked against the map
  /// yet: a start far off is found at once).
  bool search_at_start = true;
  /// Radius of a wide search around the prediction, m.
  double search_wide_radius_m = 400.0;
  /// Gate of a wide search: until the run's first fix, search_wide_radius_m (the prediction is
  /// not trusted yet); after it, the attempts' gate plus this times the track's distance flown
  /// since the last fix (the odometry's drift, a fraction of the distance), at most the radius.
  double search_gate_per_m = 0.1;
  /// An attempt searching farther than this (search_radius_m, or a wide search), m, goes coarse
  /// to fine: Search at the coarse resolution, then Match around its hit.
  double coarse_above_radius_m = 150.0;
  /// The coarse resolution of a search brings the frame to this many pixels across (never finer
  /// than the matching resolution): the search window's area, and its cost, fall with its square.
  int search_width_px = 256;
  /// A search's hit must have this many times the inliers of the best other location, and
  /// min_inliers more (a repeated texture, a field of the same rows, two map tiles that each
  /// hold part of the frame's ground: no fix).
  double min_margin = 2.0;
  /// Without a geo-reference (no GPS before the first fix): the whole map's data is searched in
  /// square tiles of at most 2 search_wide_radius_m a side, at most this many (those nearest the
  /// maps' centre; pipeline/map_fixer.h SearchWholeMap).
  int whole_map_max_tiles = 64;
  /// A prior for that search (a start position the user knows, WGS84 degrees): with
  /// start_radius_m > 0 only the square of 2 start_radius_m a side around it is searched
  /// (whole_map_max_tiles still bounds it), not the whole map. 0 = none.
  double start_lat_deg = 0.0, start_lon_deg = 0.0, start_radius_m = 0.0;
  /// Without a geo-reference: the frames wait for the map's seed (pipeline/run_steps.h
  /// RunOutputs holds them, about 0.5 kB each, and writes none) at most this long, seconds of the
  /// source's time from its first frame; then they are written in the local frame, the run stays
  /// local (no later seed: frames.csv never mixes frames) and summary.json map_fixes.georef.note
  /// says so (pipeline/stage_map_fix.cc).
  double seed_wait_s = 120.0;
};

/// Throws InvalidArgument naming the bad field.
void Validate(const MapMatchOptions& options);

// clang-format off
template <class V>
void VisitFields(MapMatchOptions& o, V& v) {
  using namespace options;
  v.Field(o.every_n_frames, "every_n_frames", "Match every n-th frame against the map (--map)", Interval(1, 1000000));
  v.Field(o.apply, "apply", "The fixes move the track: fused into the pose graph (absolute factors with their covariance, gated against the track; docs/map.md)", Any());
  v.Field(o.match_m_per_px, "match_m_per_px", "Ground resolution of map matching, m/px (0 = the coarser of the map's and the frame's at match_width_px)", AtLeast(0).Finite());
  v.Field(o.match_width_px, "match_width_px", "Automatic resolution: the frame's width at the matching resolution, px", Interval(64, 4096));
  v.Field(o.search_radius_m, "search_radius_m", "Search radius around the predicted position, m; farther fixes are rejected (gate)", GreaterThan(0).Finite());
  v.Field(o.gate_m, "gate_m", "Fixes farther than this from the prediction are rejected, m (0 = search_radius_m)", AtLeast(0).Finite());
  v.Field(o.frame_points, "frame_points", "SURF points of the frame (the map window's: scaled by its area)", Interval(16, 100000));
  v.Field(o.max_map_points, "max_map_points", "Most SURF points of the map window", Interval(16, 1000000));
  v.Field(o.tile_cache, "tile_cache", "Detect the map's points once per map tile and keep them for the next attempts (local attempts; the automatic resolution in steps of 9 %)", Any());
  v.Field(o.max_distance_px, "max_distance_px", "RANSAC inlier threshold at the matching resolution, px", GreaterThan(0).Finite());
  v.Field(o.ransac_trials, "ransac_trials", "Most RANSAC trials of a fix", Interval(1, 1000000));
  v.Field(o.seed, "seed", "Seed of the fix's RANSAC", Any());
  v.Field(o.min_inliers, "min_inliers", "Fewest inliers of a fix", Interval(3, 1000000));
  v.Field(o.min_spread, "min_spread", "Smallest spread of the inliers over the frame (principal std / smaller side)", AtLeast(0).Finite());
  v.Field(o.max_scale_error, "max_scale_error", "Largest relative error of the fit's scale", GreaterThan(0).Finite());
  v.Field(o.max_heading_error_deg, "max_heading_error_deg", "Largest rotation of the fit against the heading, deg (gate)", GreaterThan(0).Finite());
  v.Field(o.min_contrast, "min_contrast", "Smallest robust intensity range of the map window and the frame, grey levels", AtLeast(0).Finite());
  v.Field(o.min_valid_fraction, "min_valid_fraction", "Smallest share of the window with map data", Interval(0, 1));
  v.Field(o.min_frame_width_px, "min_frame_width_px", "Fewest pixels across the frame at the map's resolution: a map coarser than that is not matched (map_too_coarse)", Interval(16, 4096));
  v.Field(o.search_after_failures, "search_after_failures", "Consecutive failed attempts (few_inliers, ambiguous, spread, scale, gate) that start a wide search (0 = never)", Interval(0, 1000000));
  v.Field(o.search_at_start, "search_at_start", "The run's first attempt is a wide search", Any());
  v.Field(o.search_wide_radius_m, "search_wide_radius_m", "Radius of a wide search around the prediction, m", GreaterThan(0).Finite());
  v.Field(o.search_gate_per_m, "search_gate_per_m", "Gate of a wide search after a fix: the gate plus this times the distance flown since the last fix (before the first fix: the wide radius)", AtLeast(0).Finite());
  v.Field(o.coarse_above_radius_m, "coarse_above_radius_m", "Searches wider than this radius, m, go coarse to fine", GreaterThan(0).Finite());
  v.Field(o.search_width_px, "search_width_px", "Coarse resolution of a search: the frame's width at it, px (never finer than the matching resolution)", Interval(64, 4096));
  v.Field(o.whole_map_max_tiles, "whole_map_max_tiles", "Without a geo-reference: most tiles (2 x search_wide_radius_m a side) of the whole-map search", Interval(1, 10000));
  v.Field(o.start_lat_deg, "start_lat_deg", "Without a geo-reference: latitude of a known start position, deg (with start_radius_m)", Interval(-90, 90));
  v.Field(o.start_lon_deg, "start_lon_deg", "Without a geo-reference: longitude of a known start position, deg (with start_radius_m)", Interval(-180, 180));
  v.Field(o.start_radius_m, "start_radius_m", "Without a geo-reference: search this far around the start position instead of the whole map, m (0 = the whole map)", AtLeast(0).Finite());
  v.Field(o.seed_wait_s, "seed_wait_s", "Without a geo-reference: the frames wait at most this long for the map's seed, s of the source's time; then they are written in the local frame and the run stays local", GreaterThan(0).Finite());
  v.Field(o.min_margin, "min_margin", "A search's hit needs this many times the inliers of the best other location (and min_inliers more)", AtLeast(1).Finite());
}
// clang-format on

/// What became of a fix attempt.
enum class MapFixStatus {
  kFix,             ///< A fix.
  kNoMap,           ///< No map window (outside the maps, too little data in it).
  kNoMapTexture,    ///< The window has too little contrast or too few SURF points.
  kNoFrameTexture,  ///< The frame has too little contrast or too few SURF points.
  kTooFewInliers,   ///< RANSAC found fewer than min_inliers.
  kSpread,          ///< The inliers lie in a line or a corner of the frame.
  kScale,           ///< The fit's scale disagrees with the frame's ground sampling distance.
  kGate,            ///< Farther than the gate (gate_m) from the prediction, or rotated against
                    ///< the heading by more than max_heading_error_deg.
  kAmbiguous,       ///< A search's hit has under min_margin times the inliers of another place.
  kMapTooCoarse,    ///< The frame is under min_frame_width_px across at the attempt's
                    ///< resolution (the map's, when it is the coarser): not matched.
};
inline constexpr int kNumMapFixStatus = 10;
/// "fix", "no_map", "no_map_texture", "no_frame_texture", "few_inliers", "spread", "scale",
/// "gate", "ambiguous", "map_too_coarse".
const char* ToString(MapFixStatus status);

/// The frame to fix.
struct MapMatchFrame {
  GrayImageView pixels;               ///< Preprocessed nadir grey frame.
  double focal_px = 0.0;              ///< Focal length at this resolution, px (> 0).
  double height_m = 0.0;              ///< Height above ground, m (> 0).
  std::optional<double> heading_rad;  ///< ENU heading estimate (file comment), if any.
};

/// The map around the prediction.
struct MapMatchWindow {
  GrayImageView pixels;  ///< North-up grey window.
  GrayImageView valid;   ///< 255 where the map has data (same size), else 0.
  double m_per_px = 0.0;
};

/// The map around the prediction given by its SURF points instead of its pixels
/// (MapMatcher::MatchFeatures): what a cache of the map's points hands over (pipeline/
/// map_tiles.h). A square north-up window as MapMatchWindow's, pixel (x, y) at east = (x - (size
/// - 1) / 2) m_per_px, north = ((size - 1) / 2 - y) m_per_px of its centre.
struct MapWindowFeatures {
  /// SURF points (DetectMapFeatures; upright when the frame's heading is known), window px.
  FeatureSet features;
  int size_px = 0;           ///< Side of the window, px.
  double m_per_px = 0.0;     ///< Its resolution.
  std::size_t valid_px = 0;  ///< Its pixels with map data (min_valid_fraction's measure).
  /// The robust intensity range of those pixels, grey levels (min_contrast's measure,
  /// MapRobustRange).
  double contrast = 0.0;
};

/// One attempt, by value.
struct MapFix {
  MapFixStatus status = MapFixStatus::kNoMap;
  /// The fit (status kFix, or a check's failure after the fit: kSpread, kScale, kGate).
  bool fitted = false;
  Eigen::Vector2d enu_m = Eigen::Vector2d::Zero();  ///< Frame centre, window ENU, m.
  double heading_rad = 0.0;                         ///< ENU heading of the frame (file comment).
  double scale = 1.0;  ///< The fit's scale against the expected one (1 = the height is right).
  /// Covariance of (east, north), m^2, and of the heading, rad^2, from the fit's residuals.
  Eigen::Matrix2d position_cov_m2 = Eigen::Matrix2d::Zero();
  double heading_var_rad2 = 0.0;
  int inliers = 0;
  int matches = 0;
  /// A search (MapMatcher::Search): inliers of the best fit at a place away from this one's.
  int second_inliers = 0;
  int frame_points = 0, map_points = 0;
  double residual_m = 0.0;        ///< RMS transfer error of the inliers, m.
  double spread = 0.0;            ///< MapMatchOptions::min_spread's measure.
  double prior_distance_m = 0.0;  ///< |enu_m - prior|, m.
  double ms = 0.0;                ///< Time of the attempt, ms.
  double m_per_px = 0.0;          ///< The attempt's resolution (the window's), m/px.
  double frame_width_m = 0.0;     ///< The frame's width on the ground, m.
};

/// Side of the square window (px at `m_per_px`) that holds the frame's footprint anywhere within
/// `search_radius_m` of its centre, whatever the heading.
int MapWindowSizePx(int frame_width_px, int frame_height_px, double gsd_m_per_px,
                    double search_radius_m, double m_per_px);

/// The matching resolution (MapMatchOptions::match_m_per_px, or automatic), m/px.
double MapMatchResolution(const MapMatchOptions& options, int frame_width_px, double gsd_m_per_px,
                          double map_m_per_px);

/// The resolution of a search's coarse window: the frame's ground width over search_width_px,
/// at least the matching resolution, m/px.
double MapSearchResolution(const MapMatchOptions& options, int frame_width_px, double gsd_m_per_px,
                           double map_m_per_px);

/// The options of a search's refinement (Match around the coarse hit): search radius and gate
/// of 8 coarse pixels, at least 10 m.
MapMatchOptions MapRefineOptions(const MapMatchOptions& options, double coarse_m_per_px);

/// The robust intensity range of a grey histogram: 1st to 99th percentile, grey levels; 0 when
/// it is empty (MapMatchOptions::min_contrast's measure).
double MapRobustRange(const std::array<std::int64_t, 256>& histogram);

/// `m_per_px` rounded to the nearest of the ladder 2^(k/8) m/px (k integer; steps of 9 %): the matching
/// resolutions a cache of the map's points is kept at (pipeline/map_tiles.h), so that a height
/// that changes a little does not change the resolution.
double MapLadderResolution(double m_per_px);

/// The SURF points of a map image as MapMatcher matches them: invalid pixels (`valid` 0) set
/// to the valid ones' mean, adaptive SURF (upright or not) for about `target_points` points,
/// the points whose descriptor disc (12 scales) reaches an invalid pixel or the border dropped.
/// Throws InvalidArgument when `valid` is not `pixels`' size.
FeatureSet DetectMapFeatures(const GrayImageView& pixels, const GrayImageView& valid,
                             int target_points, bool upright);

/// Reusable matcher (SURF engines, matcher and RANSAC buffers). Not thread-safe: one per thread.
class MapMatcher {
 public:
  /// Throws InvalidArgument for invalid options.
  explicit MapMatcher(const MapMatchOptions& options);
  ~MapMatcher();
  MapMatcher(MapMatcher&&) noexcept;
  MapMatcher& operator=(MapMatcher&&) noexcept;

  const MapMatchOptions& options() const;

  /// One fix of `frame` against `window`, `prior_enu_m` the predicted position of the frame
  /// centre in the window's ENU (m). Throws InvalidArgument for an empty frame or window, a
  /// valid mask of another size, or focal_px, height_m, m_per_px not finite and > 0.
  MapFix Match(const MapMatchFrame& frame, const MapMatchWindow& window,
               const Eigen::Vector2d& prior_enu_m);

  /// The coarse step of a search with a weak prior: `window` is wide (a radius of hundreds of
  /// metres) at a coarse resolution (MapSearchResolution); the frame is matched against all of
  /// it, unguided (rotation-invariant without a heading; min_valid_fraction does not apply: the
  /// window may reach far beyond a small map). The best fit is checked as Match's,
  /// with `gate_m` as its gate, and against the best fit elsewhere (the matches outside the
  /// first fit's footprint): under min_margin times its inliers, or fewer than min_inliers more, it
  /// is kAmbiguous. A kFix is the
  /// coarse hit, to be refined by Match at the matching resolution around it (MapRefineOptions).
  /// Throws as Match.
  MapFix Search(const MapMatchFrame& frame, const MapMatchWindow& window,
                const Eigen::Vector2d& prior_enu_m, double gate_m);

  /// Match with the map window given by its points (a cache's): the same checks, prior, gate
  /// and fit as Match, with `map`'s valid_px and contrast for the window's data and texture.
  /// Throws as Match, and for a size under 2 px.
  MapFix MatchFeatures(const MapMatchFrame& frame, const MapWindowFeatures& map,
                       const Eigen::Vector2d& prior_enu_m);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace aerovo
