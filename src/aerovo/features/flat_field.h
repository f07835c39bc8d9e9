// Sensor non-uniformity (a "flat field"): the part of a flight's frames that stays still in the
// frame while the ground moves through it — the lens's vignetting and the detector's fixed
// pattern (per-pixel and per-column offsets of an uncooled microbolometer, the shading of its
// housing). On a thermal camera over ground of nearly one temperature it can be larger than the
// ground's own contrast, and SURF then finds the sensor instead of the ground: every frame
// "matches" the previous one at zero motion.
//
// Model (additive, in digital numbers): frame_t(x, y) = mu_t + ground_t(x, y) + pattern(x, y),
// with mu_t the frame's mean (a thermal camera's automatic gain moves it from frame to frame),
// ground_t the moving scene and pattern zero-mean and static. The pattern is estimated from the
// flight itself as the per-pixel median (EstimateFlatField: a photo folder's subsample) or a
// running mean (RunningFlatField: video and live frames) of the mean-removed frames, whose
// moving ground averages out; the same idea as the median flat field of astronomical sky frames
// and as scene-based non-uniformity correction of infrared focal-plane arrays (Harris &
// Chiang 1999, "Nonuniformity correction of infrared image sequences using the constant-statistics
// constraint", IEEE Trans. Image Processing 8(8)). FlatFieldCorrector removes it and stretches
// the remaining contrast. No I/O.
#pragma once

#include <cstdint>
#include <vector>

#include "aerovo/core/image.h"
#include "aerovo/core/options.h"

namespace aerovo {

/// Whether the run removes the flat field (FlatFieldOptions::mode).
enum class FlatFieldMode {
  kAuto,  ///< When its significance is at least FlatFieldOptions::min_significance.
  kOn,    ///< Always (once estimated).
  kOff,   ///< Never (frames as read; the estimate is still made and reported).
};
const char* ToString(FlatFieldMode mode);
template <>
struct options::EnumTraits<FlatFieldMode>
    : options::EnumList<FlatFieldMode, ToString, FlatFieldMode::kAuto, FlatFieldMode::kOn,
                        FlatFieldMode::kOff> {};

/// The options of the flat-field stage (`aerovo run` keys flat_field.*).
struct FlatFieldOptions {
  FlatFieldMode mode = FlatFieldMode::kAuto;
  /// kAuto removes the pattern when FlatFieldEstimate::significance (the pattern's spatial
  /// standard deviation over the frames' varying part's) is at least this. 0.5 (our choice):
  /// a pattern half as strong as the ground's texture already puts SURF's strongest responses
  /// on it; the simulated thermal flight measures about 1.4, the real visible flights far less
  /// (BENCHMARKS.md, "Sensor non-uniformity").
  double min_significance = 0.5;
  /// Photo folders: frames of the flight (spread evenly) whose per-pixel median is the
  /// estimate. 21 (our choice): the median of 21 samples has sqrt(pi / 2 / 21) = 0.27 of one
  /// sample's spread (15 left a frame of the simulated thermal flight bridged, 21 none), and
  /// reading them costs a run a fraction of a second (BENCHMARKS.md, "Sensor non-uniformity").
  int photo_samples = 21;
  /// Video and live frames: a frame joins the running estimate when at least this many
  /// seconds (of the source's time) passed since the last one that joined, so that the ground
  /// has moved between samples. 0.5 s (our choice): at 5 m/s and 100 m above ground a 45 degree
  /// camera has moved 3 % of its footprint.
  double sample_interval_s = 0.5;
  /// Video and live frames: samples before the estimate is judged and used (frames before are
  /// processed as read).
  int warmup_samples = 20;
  /// Video and live frames: the running mean's window, samples (an exponential average of
  /// weight 1 / window once more samples joined; before, the plain mean). 120 samples = 60 s
  /// at 0.5 s: long enough for the ground to move several footprints.
  int window_samples = 120;
  /// Contrast stretch after the removal: the varying part's standard deviation becomes this
  /// many DN (within gain 1..max_gain). 32 DN: +-4 standard deviations within 0..255.
  double target_std_dn = 32.0;
  /// Largest gain of the stretch (noise grows with it).
  double max_gain = 8.0;
  /// kAuto also needs the ground seen moving through the frames the estimate is judged from
  /// (FlatFieldEstimate::ground_seen) and the two disjoint parts of the estimate sharing at most
  /// this share of their ground (FlatFieldEstimate::ground_overlap): ground that stays (a hover,
  /// a slow or short flight, photos of large overlap) is as static in the frame as the sensor's
  /// pattern, and the two parts would agree on it. 0.5 (our choice): the parts' frames share at
  /// most half of their footprint.
  double max_ground_overlap = 0.5;
};

/// Throws InvalidArgument naming the bad field.
void Validate(const FlatFieldOptions& options);

// clang-format off
template <class V>
void VisitFields(FlatFieldOptions& o, V& v) {
  using namespace options;
  v.Field(o.mode, "mode", "Remove the sensor's static pattern (vignetting, fixed-pattern noise) estimated from the flight: auto (when significant), on or off", Any());
  v.Field(o.min_significance, "min_significance", "auto: remove it when the pattern's standard deviation is at least this times the frames' varying part's", AtLeast(0).Finite());
  v.Field(o.photo_samples, "photo_samples", "Photo folders: frames (spread over the flight) whose per-pixel median is the estimate", Interval(3, 1000));
  v.Field(o.sample_interval_s, "sample_interval_s", "Video and live: least time between two frames that join the running estimate, s", AtLeast(0).Finite());
  v.Field(o.warmup_samples, "warmup_samples", "Video and live: samples before the running estimate is judged and used", Interval(2, 100000));
  v.Field(o.window_samples, "window_samples", "Video and live: window of the running mean, samples", Interval(2, 100000));
  v.Field(o.target_std_dn, "target_std_dn", "Contrast stretch after the removal: the varying part's standard deviation, DN", Interval(1, 127));
  v.Field(o.max_gain, "max_gain", "Largest gain of the contrast stretch", Interval(1, 64));
  v.Field(o.max_ground_overlap, "max_ground_overlap", "auto: remove it only when the frames of the estimate's two disjoint parts share at most this share of their ground (and the ground was seen moving)", Interval(0, 1));
}
// clang-format on

/// Pixel budget of the estimate's grid, megapixels: larger frames are binned by the smallest
/// integer factor n with (w / n) (h / n) within it (FlatFieldGridFactor), so that a photo
/// folder's samples fit in memory (31 x 1 MP). Thermal detectors (640x512, 0.33 MP) keep their
/// pixels, and so their per-pixel pattern; larger (visible) frames keep the vignetting.
inline constexpr double kFlatFieldGridMegapixels = 1.0;
/// The binning factor n of frames of width_px x height_px (>= 1).
int FlatFieldGridFactor(int width_px, int height_px);

/// The static pattern of a flight's frames, on the grid (frames binned by `factor`).
struct FlatFieldEstimate {
  int width_px = 0, height_px = 0;      ///< Of the frames.
  int factor = 1;                       ///< Grid binning factor (FlatFieldGridFactor).
  int grid_width = 0, grid_height = 0;  ///< floor(width / factor) x floor(height / factor).
  /// pattern(x, y) in DN, zero-mean, row-major on the grid (grid_width x grid_height).
  std::vector<float> pattern_dn;
  int samples = 0;  ///< Frames the estimate is made of.
  /// The part of the pattern that two estimates from disjoint parts of the flight share, DN:
  /// sqrt(max(0, spatial covariance of the two)). A sensor's pattern is in both; the estimates'
  /// noise is not, nor what the medians keep of the ground when the two parts see other ground
  /// (the photo median: the first and the last third of the samples in flight order; the running
  /// estimate: alternate blocks of samples). Whether they do is the motion test's
  /// (ground_seen, ground_overlap): a ground that stays in the frame is in both too.
  double pattern_std_dn = 0.0;
  /// Root mean square over pixels and samples of the frames' varying part (frame - mean -
  /// pattern), DN: the ground's texture and the temporal noise.
  double varying_std_dn = 0.0;
  /// pattern_std_dn / varying_std_dn (0 when the frames do not vary).
  double significance = 0.0;
  /// The motion test (GroundMotion): whether some two frames of the estimate show the ground
  /// moved between them (a clear correlation peak of their ground at a non-zero shift). Without
  /// it a static pattern and a static ground cannot be told apart.
  bool ground_seen = false;
  /// The motion test: the largest share of the frame (0..1) that a frame of one of the two
  /// disjoint parts (pattern_std_dn) has in common on the ground with its partner in the other,
  /// from the shift of their correlation peak; 1 for a pair without a peak that is still
  /// (GroundMotion::Still: the same ground at the same place), 0 for one that is not (no common
  /// ground found); 1 before any test.
  double ground_overlap = 1.0;
  bool empty() const { return samples == 0; }
};

/// Whether `options` remove `estimate`: mode kOn (a non-empty estimate), kOff never, kAuto when
/// its significance is at least min_significance, the ground was seen moving and the estimate's
/// two parts share at most max_ground_overlap of their ground.
bool FlatFieldApplies(const FlatFieldEstimate& estimate, const FlatFieldOptions& options);

/// The motion test of the flat field: frames on the estimate's grid, less an estimate of the
/// pattern, are binned to a coarse image of at most kGroundMotionPixels on its longer side and
/// band-passed (less their 5 x 5 box mean: the smooth vignetting and the ground's slow gradients
/// go, the fixed pattern's pixels and columns average out in the bins); the shift of two such
/// images is the one of largest zero-mean normalised cross-correlation (NCC) over shifts of up
/// to half the image each way. A peak of at least kGroundPeakNcc is the ground both show; its
/// shift says how far the ground moved, and the overlap (1 - |dx| / w) (1 - |dy| / h) how much
/// of it they share. Buffers allocated by the constructor; no allocation after.
inline constexpr int kGroundMotionPixels = 64;
/// A clear peak (our choice, between the two measured in
/// FlatField.GroundMotionFindsTheShiftOfSharedGroundOnly): the shared ground of two such images
/// correlates at about 0.8 with a sensor's pattern in both, and unrelated ground at most 0.23.
inline constexpr double kGroundPeakNcc = 0.5;
/// GroundMotion::Still's bound (our choice, between the two measured in
/// FlatField.StillCorrelationTellsAStaticGroundFromAMovedOne): the same ground at the same
/// place, its gain changed, correlates at 0.986 (its noise, binned, is the rest); moved by 2 px,
/// at 0.82. A pattern strong enough to keep frames of a moved ground above it leaves no ground
/// to see at this scale.
inline constexpr double kStillNcc = 0.95;

/// The best shift of two coarse images (GroundMotion::Best): b(x, y) ~ a(x + dx, y + dy).
struct GroundPeak {
  double ncc = 0.0;      ///< Zero-mean NCC at the shift (-1..1).
  int dx = 0, dy = 0;    ///< Coarse pixels.
  double overlap = 0.0;  ///< (1 - |dx| / w) (1 - |dy| / h).
  bool clear() const { return ncc >= kGroundPeakNcc; }
  bool moved() const { return clear() && (dx != 0 || dy != 0); }
};

class GroundMotion {
 public:
  GroundMotion() = default;
  /// For a grid of grid_width x grid_height (InvalidArgument if not positive).
  GroundMotion(int grid_width, int grid_height);
  int width() const { return width_; }  ///< Of the coarse images.
  int height() const { return height_; }
  std::size_t size() const { return static_cast<std::size_t>(width_) * height_; }
  /// The coarse band-passed image of `grid` (grid_width x grid_height) into `out` (size()).
  void Coarse(const float* grid, float* out);
  /// The best shift of a and b (coarse images of size()).
  GroundPeak Best(const float* a, const float* b);
  /// The zero-shift NCC of coarse images a and b (-1..1; 0 when one is flat): close to 1 when
  /// the frames show the same ground at the same place (their noise, binned, is a small part
  /// of the coarse images), lower when the ground moved (a static pattern alone keeps its part).
  double StillCorrelation(const float* a, const float* b);
  /// Whether two frames show the same ground at the same place: StillCorrelation at least
  /// kStillNcc.
  bool Still(const float* a, const float* b) { return StillCorrelation(a, b) >= kStillNcc; }

 private:
  void Tables(const float* image, std::vector<double>* sum, std::vector<double>* sum_sq);
  int grid_width_ = 0, grid_height_ = 0, factor_ = 1, width_ = 0, height_ = 0;
  std::vector<float> binned_;
  std::vector<double> sum_a_, sq_a_, sum_b_, sq_b_;  // integral tables, (w + 1) x (h + 1)
};

/// The per-pixel median of mean-removed frames (a photo folder's subsample, added in flight
/// order): each frame is binned to the grid as it is added, so only the grid samples are kept
/// (capacity x grid pixels floats, allocated by the constructor).
class MedianFlatField {
 public:
  /// Frames of width_px x height_px, at most `capacity` of them (>= 3); InvalidArgument else.
  MedianFlatField(int width_px, int height_px, int capacity);
  /// InvalidArgument for another size or beyond the capacity.
  void Add(const GrayImageView& frame);
  int samples() const { return samples_; }
  /// The estimate of the frames added (at least 3, else InvalidArgument), with the motion test:
  /// the j-th sample of the first third, less the last third's median, against the j-th of the
  /// last third, less the first third's (a ground both parts hold at one place cancels from
  /// both: such a pair shows no peak, and its stillness says it shares all); successive
  /// samples, less the median of all, until one pair shows the ground moved. Cost: a selection of samples() values per grid pixel and up to
  /// samples() - 1 + samples() / 3 shift searches (GroundMotion::Best).
  FlatFieldEstimate Estimate() const;

 private:
  FlatFieldEstimate shape_;    // sizes only
  std::vector<float> values_;  // sample-major: sample i at i * grid pixels
  int capacity_ = 0, samples_ = 0;
};

/// MedianFlatField of `frames` (all of one size, at least 3; else InvalidArgument).
FlatFieldEstimate EstimateFlatField(const std::vector<GrayImageView>& frames);

/// The running estimate of video and live frames: per grid pixel two exponentially weighted means
/// (weight 1 / min(samples, window / 2) each) of the mean-removed frames, fed by alternate blocks
/// of max(1, window / 8) samples (15 s at the defaults' 0.5 s and 120: the camera has moved on
/// between blocks), and the squared deviations; the pattern is their mean, pattern_std_dn their
/// shared part (0 until both have samples). The motion test (GroundMotion, on the frames less
/// the pattern): ground_seen once two successive samples showed the ground moved; ground_overlap
/// what the newest sample shares with the oldest of the first samples of the last 4 blocks (up
/// to half a window back, the span the running means mostly hold; the first sample while fewer
/// samples joined; 1 before the second sample; a pair without a peak: 1 if still, else 0). Buffers sized once by the constructor; Add
/// allocates nothing.
class RunningFlatField {
 public:
  /// Frames of width_px x height_px; InvalidArgument for a non-positive size or window < 1.
  RunningFlatField(int width_px, int height_px, int window_samples);
  /// Adds a frame (InvalidArgument for another size) and updates estimate().
  void Add(const GrayImageView& frame);
  const FlatFieldEstimate& estimate() const { return estimate_; }

 private:
  void TestMotion(bool block_start);

  FlatFieldEstimate estimate_;   // pattern_dn: the mean of the two running means
  std::vector<float> mean_[2];   // the two running means
  std::vector<float> variance_;  // per grid pixel, exponentially weighted
  std::vector<float> binned_;    // the frame on the grid
  int window_ = 1, block_ = 1;
  int count_[2] = {0, 0};  // samples in each mean
  // The motion test (GroundMotion): coarse images of the newest and the previous sample, of
  // the first samples of the last kSnapshots blocks (a ring), the pattern's, and residuals.
  static constexpr int kSnapshots = 4;
  GroundMotion motion_;
  std::vector<float> now_, previous_, snapshots_, pattern_, ra_, rb_;
  long snapshots_taken_ = 0;
};

/// Removes a flat field from frames and stretches their contrast:
///   out = clamp(round(128 + g (in - pattern - mean(in - pattern)))), g = clamp(target_std_dn /
///   varying_std_dn, 1, max_gain),
/// the pattern bilinearly interpolated from the grid to the frame's pixels (once per Set).
/// Buffers reused: Apply allocates nothing after the first frame of a size.
class FlatFieldCorrector {
 public:
  /// Takes `estimate` (not empty, else InvalidArgument) and the stretch of `options`.
  void Set(const FlatFieldEstimate& estimate, const FlatFieldOptions& options);
  bool ready() const { return ready_; }
  int width() const { return width_; }  ///< Of the frames of the estimate set (0 before).
  int height() const { return height_; }
  double gain() const { return gain_; }
  /// The corrected copy of `frame` (the estimate's size, else InvalidArgument), in a buffer of
  /// the corrector: valid until the next Apply.
  GrayImageView Apply(const GrayImageView& frame);

 private:
  std::vector<float> pattern_;  // at the frame's resolution
  int width_ = 0, height_ = 0;
  double gain_ = 1.0;
  bool ready_ = false;
  GrayImage out_;
};

}  // namespace aerovo
