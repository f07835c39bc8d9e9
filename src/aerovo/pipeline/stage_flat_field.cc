// The flat-field stage: the sensor's static pattern (vignetting, fixed-pattern noise; features/
// flat_field.h) estimated from the flight and removed from every frame as read, before the
// reduction, undistortion and SURF (stage_preprocess.cc starts from FrameState::pixels when this
// stage set it), when significant (RunConfig::flat_field). A photo folder: on the first frame a
// pre-pass reads flat_field.photo_samples photos spread evenly over the flight (a second frame
// source, random access; the main stream is not touched) and takes their per-pixel median. Video
// and live frames: a running mean fed with a frame every sample_interval_s of the source's time,
// judged and used after warmup_samples, then on or off with hysteresis (off below 3/4 of
// min_significance or above 3/2 of max_ground_overlap). What it did: summary.json "flat_field"
// (RunSummary::flat_field).
#include <algorithm>
#include <memory>
#include <optional>
#include <string>

#include <fmt/format.h>

#include "aerovo/core/error.h"
#include "aerovo/core/timer.h"
#include "aerovo/features/flat_field.h"
#include "aerovo/pipeline/frame_loop.h"
#include "aerovo/pipeline/lens_prepass.h"

namespace aerovo::run_steps {
namespace {

// A running estimate that is applied is handed to the corrector again (FlatFieldCorrector::Set,
// which interpolates it to the frame's pixels, the stage's largest cost on a 1080p frame) every
// this many samples: 5 s at the default 0.5 s, while the pattern's estimate moves with a window
// of 60 s. Our choice.
constexpr int kRefreshSamples = 10;

// Photos of a first look (the pre-pass's screening): a flight whose pattern measures below half
// of min_significance on them is not read further. 7 (our choice): the first and last third have
// 2 photos each; a visible flight then costs a third of the full pre-pass, a thermal flight a
// third more (BENCHMARKS.md, "Sensor non-uniformity").
constexpr int kScreenSamples = 7;

// The median of `n` (>= 3) photos of `folder` spread evenly ((i + 0.5) / n of the way) over the
// `frames` the run delivers (from photo `first`, every `step`), of width_px x height_px (photos
// of another size are left out and counted in `other_size`). nullopt when fewer than 3 are left.
std::optional<FlatFieldEstimate> MedianOf(ImageFolderSource& folder, std::size_t first, int step,
                                          int frames, int n, int width_px, int height_px,
                                          int* other_size) {
  MedianFlatField median(width_px, height_px, n);
  Frame frame;
  *other_size = 0;
  for (int i = 0; i < n; ++i) {
    const std::size_t rank = static_cast<std::size_t>((i + 0.5) * frames / n);
    folder.Read(first + rank * static_cast<std::size_t>(step), frame);
    if (frame.gray.width() != width_px || frame.gray.height() != height_px) {
      ++*other_size;
      continue;
    }
    median.Add(frame.gray.view());
  }
  if (median.samples() < 3) return std::nullopt;
  return median.Estimate();
}

// The photo folder's pre-pass (see the top): with mode auto, a first look at kScreenSamples
// photos, then the median of photo_samples photos unless the first look found nothing. nullopt,
// with `why`, when fewer than 3 photos could be used.
std::optional<FlatFieldEstimate> PhotoMedian(const RunConfig& config, int width_px, int height_px,
                                             std::string* why) {
  const FrameSourceOptions so = SourceOptionsOf(config);
  std::unique_ptr<FrameSource> source = OpenFrameSource(config.input, so);
  auto* folder = dynamic_cast<ImageFolderSource*>(source.get());
  if (folder == nullptr) {
    *why = "the input is not a photo folder";
    return std::nullopt;
  }
  std::size_t first = 0;
  while (first < folder->paths().size() && folder->TimeOf(first) < so.start_time_s) ++first;
  const FlatFieldOptions& o = config.flat_field;
  const int frames = folder->ExpectedFrameCount();
  const int n = std::min(frames, o.photo_samples);
  if (n < 3) {
    *why = fmt::format("{} photos: at least 3 are needed", std::max(frames, 0));
    return std::nullopt;
  }
  int other_size = 0;
  std::optional<FlatFieldEstimate> e;
  if (o.mode == FlatFieldMode::kAuto && n > kScreenSamples) {
    e = MedianOf(*folder, first, so.step, frames, kScreenSamples, width_px, height_px, &other_size);
    if (e && e->significance < 0.5 * o.min_significance) {
      *why =
          fmt::format("first look at {} photos (below half of min_significance): ", kScreenSamples);
      return e;
    }
  }
  e = MedianOf(*folder, first, so.step, frames, n, width_px, height_px, &other_size);
  if (!e) {
    *why = fmt::format("fewer than 3 of {} photos have the first photo's size", n);
  } else if (other_size > 0) {
    *why = fmt::format("{} photos of another size left out; ", other_size);
  }
  return e;
}

// Why FlatFieldApplies(e, o) is `apply`, in a few words.
std::string Rule(const FlatFieldEstimate& e, const FlatFieldOptions& o, bool apply) {
  if (o.mode == FlatFieldMode::kOn) return "mode on";
  if (e.significance < o.min_significance) return fmt::format("< {:.2f}", o.min_significance);
  const std::string motion =
      fmt::format("ground seen moving: {}, the parts share {:.0f} % of their ground",
                  e.ground_seen ? "yes" : "no", 100.0 * e.ground_overlap);
  if (apply) return fmt::format(">= {:.2f}, {}", o.min_significance, motion);
  return fmt::format(">= {:.2f} but undecided: {} (at most {:.0f} % and moving needed)",
                     o.min_significance, motion, 100.0 * o.max_ground_overlap);
}

class FlatFieldStage : public FrameStage {
 public:
  const char* name() const override { return "flat_field"; }

  void Process(FrameState& f, const RunContext& run) override {
    const Stopwatch sw;
    const GrayImageView raw = f.frame.gray.view();
    FlatFieldReport& report = run.summary->flat_field;
    const FlatFieldOptions& o = run.config->flat_field;
    double prepass_ms = 0.0;
    if (!started_) {
      Start(raw, run);
      prepass_ms = report.prepass_ms;
    }
    if (running_ && raw.width == running_->estimate().width_px &&
        raw.height == running_->estimate().height_px && f.frame.time_s >= next_sample_s_) {
      next_sample_s_ = f.frame.time_s + o.sample_interval_s;
      running_->Add(raw);
      ++samples_since_set_;
      if (running_->estimate().samples >= o.warmup_samples) Decide(running_->estimate(), run);
    }
    if (applied_ && raw.width == corrector_.width() && raw.height == corrector_.height()) {
      f.pixels = corrector_.Apply(raw);
      ++report.frames_corrected;
      report.applied = true;
    }
    total_ms_ += sw.elapsed_ms() - prepass_ms;
    report.mean_frame_ms = total_ms_ / ++frames_;
  }

 private:
  // On the first frame: the photo folder's median, or the running estimate's buffers.
  void Start(const GrayImageView& first, const RunContext& run) {
    started_ = true;
    const FlatFieldOptions& o = run.config->flat_field;
    FlatFieldReport& report = run.summary->flat_field;
    report.mode = ToString(o.mode);
    if (o.mode == FlatFieldMode::kOff) {
      report.why = "flat_field.mode off";
      return;
    }
    if (!run.photo_folder) {
      running_.emplace(first.width, first.height, o.window_samples);
      report.estimate = "running";
      report.why = fmt::format("running estimate: not judged before {} samples", o.warmup_samples);
      return;
    }
    const Stopwatch sw;
    std::string why;
    std::optional<FlatFieldEstimate> e;
    try {
      e = PhotoMedian(*run.config, first.width, first.height, &why);
    } catch (const InputError& error) {
      why = std::string("a photo could not be read: ") + error.what();
    }
    report.prepass_ms = sw.elapsed_ms();
    if (!e) {
      report.why = "no estimate: " + why;
    } else {
      report.estimate = "photo median";
      report.why = why;
      Decide(*e, run);
    }
    if (run.log) {
      *run.log << fmt::format("flat field: {} ({:.0f} ms)\n", report.why, report.prepass_ms);
    }
  }

  // Applies the estimate or not (FlatFieldApplies; a running estimate that was applied stays
  // so down to 3/4 of min_significance and up to 3/2 of max_ground_overlap), and records the
  // decision.
  void Decide(const FlatFieldEstimate& e, const RunContext& run) {
    const FlatFieldOptions& o = run.config->flat_field;
    FlatFieldOptions keep = o;
    if (applied_ && o.mode == FlatFieldMode::kAuto) {
      keep.min_significance *= 0.75;
      keep.max_ground_overlap = std::min(1.0, 1.5 * o.max_ground_overlap);
    }
    const bool apply = FlatFieldApplies(e, keep);
    if (apply && (!applied_ || samples_since_set_ >= kRefreshSamples)) {
      corrector_.Set(e, o);
      samples_since_set_ = 0;
    }
    FlatFieldReport& report = run.summary->flat_field;
    report.samples = e.samples;
    report.significance = e.significance;
    report.pattern_std_dn = e.pattern_std_dn;
    report.varying_std_dn = e.varying_std_dn;
    report.ground_seen = e.ground_seen;
    report.ground_overlap = e.ground_overlap;
    report.gain = apply ? corrector_.gain() : 1.0;
    if (apply == applied_ && running_) return;  // the running decision's text stays
    applied_ = apply;
    report.why = (running_ ? std::string() : report.why) +
                 fmt::format(
                     "{} of {} frames: pattern {:.2f} DN over a varying part of {:.2f} DN, "
                     "significance {:.2f} ({}): {}",
                     report.estimate, e.samples, e.pattern_std_dn, e.varying_std_dn, e.significance,
                     Rule(e, keep, apply), apply ? "removed" : "not removed");
    if (running_ && run.log) *run.log << "flat field: " << report.why << "\n";
  }

  bool started_ = false, applied_ = false;
  std::optional<RunningFlatField> running_;
  double next_sample_s_ = -1e300;
  int samples_since_set_ = 0;
  FlatFieldCorrector corrector_;
  double total_ms_ = 0.0;
  long frames_ = 0;
};

}  // namespace

std::unique_ptr<FrameStage> MakeFlatFieldStage() { return std::make_unique<FlatFieldStage>(); }

}  // namespace aerovo::run_steps
