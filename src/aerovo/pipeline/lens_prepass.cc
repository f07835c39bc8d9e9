#include "aerovo/pipeline/lens_prepass.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <utility>

#include <fmt/format.h>

#include "aerovo/core/error.h"
#include "aerovo/camera/lens.h"
#include "aerovo/core/timer.h"
#include "aerovo/features/surf.h"
#include "aerovo/frames/video_decoder.h"
#include "aerovo/matching/matcher.h"
#include "aerovo/pipeline/preprocess.h"
#include "aerovo/pipeline/run_steps.h"

namespace aerovo::run_steps {

namespace {
// The run's decision threshold on the total cost drop (LensEstimationOptions::min_cost_drop;
// the estimator's default 0.25). Measured (BENCHMARKS.md "Lens self-calibration"): tampa-phantom3
// drops 2 %, turin-p4m 24.8 % (fisheye k1 -0.046 on its 1600x1300 bands: a residual lens, or
// relief, just under 0.25), the simulated wide lenses 85-89 %: 0.5 keeps a wide margin on both
// sides. Our choice.
constexpr double kRunMinCostDrop = 0.5;
}  // namespace

FrameSourceOptions SourceOptionsOf(const RunConfig& config) {
  FrameSourceOptions so;
  so.step = config.step;
  so.start_time_s = config.start_s;
  if (config.end_s >= 0.0) so.end_time_s = config.end_s;
  so.photo_gap_s = config.photo_gap_s;
  so.photo_flight = config.photo_flight;
  so.photo_band = config.photo_band;
  so.video_decoder = config.video_decoder;
  so.video_threads = config.video_threads;
  return so;
}

std::string LensPrepassSkipReason(const RunConfig& config, bool live) {
  if (config.lens_estimation == LensEstimationMode::kOff) return "lens_estimation off";
  if (!config.calibration.empty()) return "a calibration file is given";
  if (config.k1 != 0.0 || config.k2 != 0.0 || config.p1 != 0.0 || config.p2 != 0.0 ||
      config.k3 != 0.0) {
    return "lens distortion coefficients are given";
  }
  if (live) return "";
  std::error_code ec;
  if (config.input.empty() || !std::filesystem::exists(config.input, ec)) {
    return "the input is not a file or folder that can be read again";
  }
  return "";
}

namespace {
// Frames a decoder may output after the packet that starts them (H.264's largest reorder depth,
// ITU-T H.264 A.3.1 max_dpb_frames 16): within this many frames of a pair, every frame is
// decoded, so the pair's own frames are never skipped.
constexpr int kReorderFrames = 16;
// The run's stop flag on the pre-pass's thread (LensPrepassTask; null: none).
thread_local const std::atomic<bool>* t_stop = nullptr;
// Cancelled once the run's stop flag is set: checked per frame decoded and per pair matched.
void ThrowIfStopped() {
  if (t_stop != nullptr && t_stop->load(std::memory_order_relaxed)) {
    throw Cancelled("the lens pre-pass");
  }
}
}  // namespace

std::string AttitudePrepassSkipReason(const RunConfig& config, bool live, bool autopilot_attitude,
                                      const std::optional<TelemetrySample>& first_sample,
                                      bool photo_folder) {
  if (config.attitude_estimation == AttitudeEstimationMode::kOff) return "attitude_estimation off";
  if (config.attitude == AttitudeMode::kOff) return "attitude off";
  if (config.camera_mount_pitch_deg != 0.0) return "a camera mount pitch is given";
  if (autopilot_attitude) return "the autopilot's ATTITUDE gives it";
  if (first_sample && (first_sample->gimbal_pitch_deg || first_sample->gimbal_roll_deg ||
                       first_sample->pitch_deg || first_sample->roll_deg)) {
    return "the telemetry gives it";
  }
  if (live) return "a live source cannot be read twice";
  if (!photo_folder) {
    return "not a photo folder (a video's first pose does not wait for a tilt estimate; give "
           "--camera-mount-pitch-deg)";
  }
  std::error_code ec;
  if (config.input.empty() || !std::filesystem::exists(config.input, ec)) {
    return "the input is not a file or folder that can be read again";
  }
  return "";
}

std::vector<int> LensPrepassPairStarts(int frames, int pairs) {
  std::vector<int> starts;
  if (frames < 2 || pairs < 1) return starts;
  for (int i = 0; i < pairs; ++i) {
    const int k = std::min(frames - 2, static_cast<int>(std::floor((i + 0.5) * frames / pairs)));
    if (starts.empty() || k > starts.back()) starts.push_back(k);
  }
  return starts;
}

namespace {

// The frame pairs of a video with the FFmpeg decoder: pair i at video frame starts[i] (increasing)
// and the one `step` after it. ONE decoder reads forward from pair to pair, and seeks
// (VideoDecoder::SeekBefore: to the key frame before) only when the next pair is more than
// kLensPrepassSeekS ahead: the seek costs the frames from that key frame on, up to a key-frame
// interval, and finds the frames by their timestamps, so a pair may start at the key frame
// when the container's index lands after the frame asked for. Frames between pairs are never
// converted (VideoDecoder::Grab alone), and those no other frame refers to not even decoded
// (B frames: three quarters of the simulator's H.264 frames); the pairs' frames decode exactly
// as when reading every frame.
std::vector<std::pair<Frame, Frame>> ReadVideoPairsFfmpeg(const RunConfig& config, int threads,
                                                          double fps, int step,
                                                          const std::vector<int>& starts) {
  VideoDecoder decoder(config.input, threads);
  const std::string name = std::filesystem::path(config.input).filename().string();
  const auto gray = [&](int index, Frame& out) {
    decoder.Gray(out.gray);
    out.index = index;
    out.name = fmt::format("{}#{}", name, index);
  };
  std::vector<std::pair<Frame, Frame>> pairs;
  int pos = -1;            // the video frame last grabbed
  bool by_time = fps > 0;  // frames found by their timestamps (else counted)
  // Grabs up to frame `to`. More than kReorderFrames before it, non-reference frames are not
  // decoded (VideoDecoder::SkipNonReferenceFrames) and the frames are found by their timestamps;
  // a stream without them is counted frame by frame, every frame decoded.
  const auto advance = [&](int to) {
    while (pos < to) {
      ThrowIfStopped();
      decoder.SkipNonReferenceFrames(by_time && to - pos > kReorderFrames);
      if (!decoder.Grab()) return false;
      const double ts = decoder.timestamp_ms();
      by_time = by_time && std::isfinite(ts);
      pos = by_time ? std::max(pos + 1, static_cast<int>(std::llround(ts * fps / 1000.0))) : pos + 1;
    }
    return true;
  };
  for (int a : starts) {
    if (fps > 0.0 && a - pos > kLensPrepassSeekS * fps && decoder.SeekBefore(a / fps)) {
      if (!decoder.Grab() || !std::isfinite(decoder.timestamp_ms())) break;
      pos = static_cast<int>(std::llround(decoder.timestamp_ms() * fps / 1000.0));
      a = std::max(a, pos);
    }
    std::pair<Frame, Frame> p;
    if (!advance(a)) break;
    a = pos;  // past `a` when `a` was not decoded
    gray(pos, p.first);
    if (!advance(a + step)) break;
    gray(pos, p.second);
    pairs.push_back(std::move(p));
  }
  return pairs;
}

// The frame pairs of a video, pair i at video frame starts[i] (increasing) and the one `step`
// after it: ReadVideoPairsFfmpeg, or with video_decoder opencv the run's own source read forward
// frame by frame. Either way ONE source: one per pair, each seeking exactly by decoding from
// the start (VideoFileSource's decode-and-skip), decoded up to 2.5x the clip. The run's checks
// of the stream (cut files, clocks, repeats) stay with the main source.
std::vector<std::pair<Frame, Frame>> ReadVideoPairs(const RunConfig& config,
                                                    const FrameSourceOptions& so, double fps,
                                                    const std::vector<int>& starts) {
  if (so.video_decoder != VideoDecoderChoice::kOpenCv) {
    return ReadVideoPairsFfmpeg(config, so.video_threads, fps, so.step, starts);
  }
  FrameSourceOptions from_start = so;
  from_start.start_time_s = 0.0;
  from_start.step = 1;
  from_start.end_time_s = std::numeric_limits<double>::infinity();
  VideoFileSource source(config.input, from_start);
  std::vector<std::pair<Frame, Frame>> pairs(starts.size());
  std::vector<int> got(starts.size(), 0);
  const int last = starts.empty() ? -1 : starts.back() + so.step;
  Frame f;
  for (int index = 0; index <= last && source.Next(f); ++index) {
    ThrowIfStopped();
    for (std::size_t i = 0; i < starts.size(); ++i) {
      if (index == starts[i]) pairs[i].first = f, ++got[i];
      if (index == starts[i] + so.step) pairs[i].second = f, ++got[i];
    }
  }
  std::vector<std::pair<Frame, Frame>> out;
  for (std::size_t i = 0; i < starts.size(); ++i) {
    if (got[i] == 2) out.push_back(std::move(pairs[i]));
  }
  return out;
}

// The pairs of frames as the run would deliver them (see the header): photo folders by random
// access, videos read forward once (ReadVideoPairs). `read_ms` receives the time spent.
std::vector<std::pair<Frame, Frame>> ReadPairs(const RunConfig& config, double* read_ms,
                                               std::string* why) {
  const Stopwatch sw;
  std::vector<std::pair<Frame, Frame>> pairs;
  const FrameSourceOptions so = SourceOptionsOf(config);
  std::unique_ptr<FrameSource> probe = OpenFrameSource(config.input, so);
  if (auto* folder = dynamic_cast<ImageFolderSource*>(probe.get())) {
    std::size_t first = 0;
    while (first < folder->paths().size() && folder->TimeOf(first) < so.start_time_s) ++first;
    const int frames = folder->ExpectedFrameCount();
    for (int k : LensPrepassPairStarts(frames, kLensPrepassPairs)) {
      ThrowIfStopped();
      std::pair<Frame, Frame> p;
      const std::size_t a = first + static_cast<std::size_t>(k) * so.step;
      folder->Read(a, p.first);
      folder->Read(a + so.step, p.second);
      pairs.push_back(std::move(p));
    }
  } else if (auto* video = dynamic_cast<VideoFileSource*>(probe.get())) {
    const int frames = video->ExpectedFrameCount();
    if (frames < 0) *why = "the video's frame count or rate is unknown";
    const double fps = video->fps();
    const int first = fps > 0.0 ? static_cast<int>(std::ceil(so.start_time_s * fps - 1e-6)) : 0;
    probe.reset();
    std::vector<int> starts;  // as video frames
    for (int k : LensPrepassPairStarts(frames, kLensPrepassPairs)) starts.push_back(first + k * so.step);
    pairs = ReadVideoPairs(config, so, fps, starts);
  } else {
    *why = "the input is not a photo folder or a video file";
  }
  *read_ms = sw.elapsed_ms();
  return pairs;
}

// The matches `m` of features `a` (previous frame) and `b` as the estimator's pair: at most
// kLensPrepassMaxMatches, by an even stride over the matches.
LensPair LensPairOf(const FeatureSet& a, const FeatureSet& b, const MatchResult& m) {
  const std::size_t n = m.matches.size();
  const std::size_t kept = std::min<std::size_t>(n, kLensPrepassMaxMatches);
  LensPair pair;
  pair.prev_px.resize(2, static_cast<Eigen::Index>(kept));
  pair.curr_px.resize(2, static_cast<Eigen::Index>(kept));
  for (std::size_t i = 0; i < kept; ++i) {
    const Match& match = m.matches[i * n / kept];
    const Keypoint& p = a.keypoints[match.prev_index];
    const Keypoint& c = b.keypoints[match.curr_index];
    pair.prev_px.col(static_cast<Eigen::Index>(i)) = Eigen::Vector2d(p.x, p.y);
    pair.curr_px.col(static_cast<Eigen::Index>(i)) = Eigen::Vector2d(c.x, c.y);
  }
  return pair;
}

// The camera of w x h frames with focal length focal_px and the estimate's one coefficient.
CameraIntrinsics LensOf(const LensEstimate& e, double focal_px, int w, int h) {
  CameraIntrinsics lens = IntrinsicsFromFocalPx(focal_px, w, h);
  if (e.family == RadialFamily::kFisheyeK1) {
    lens.model = LensModel::kFisheye;
    lens.distortion = {e.k, 0.0, 0.0, 0.0};
  } else {
    lens.model = LensModel::kPinhole;
    lens.distortion = {e.k, 0.0, 0.0, 0.0, 0.0};
  }
  return lens;
}

}  // namespace

namespace {

// The lens part of the pre-pass on the matched `pairs` (reduced frames of out->width_px x
// out->height_px, the reduced focal `reduced_focal_px`): the estimate and the decision, in *out.
void EstimateLens(const RunConfig& config, const std::vector<LensPair>& pairs, int w, int h,
                  double focal_px, double reduced_focal_px, LensPrepass* out) {
  const Stopwatch estimate_sw;
  LensEstimationOptions o;
  o.focal_px = reduced_focal_px;
  o.cx_px = (out->width_px - 1) / 2.0;
  o.cy_px = (out->height_px - 1) / 2.0;
  o.width_px = out->width_px;
  o.height_px = out->height_px;
  o.seed = config.odometry.correspondence.ransac.seed;
  o.min_cost_drop = kRunMinCostDrop;
  const std::string read_note = out->why;
  out->estimate = EstimateRadialDistortion(pairs, o);
  out->estimate_ms = estimate_sw.elapsed_ms();
  const LensEstimate& e = *out->estimate;
  out->why = read_note.empty() ? e.why : read_note + "; " + e.why;
  if (!e.valid) {
    out->status = LensPrepassStatus::kNoEstimate;
  } else if (!e.significant) {
    out->status = LensPrepassStatus::kNotSignificant;
  } else {
    out->status = LensPrepassStatus::kApplied;
    out->applied = true;
    out->lens = LensOf(e, focal_px, w, h);
  }
}

// The attitude part of the pre-pass on the matched `pairs` of the reduced frames: their points
// undistorted with the run's lens (`calibrated` or config's coefficients, or out->lens when the
// lens estimate is applied), then EstimateCameraAttitude; in out->attitude.
void EstimateAttitude(const RunConfig& config, std::vector<LensPair> pairs, double focal_px,
                      double reduced_focal_px, const std::optional<CameraIntrinsics>& calibrated,
                      LensPrepass* out) {
  const Stopwatch sw;
  AttitudePrepass& a = out->attitude;
  RunCamera camera;
  camera.focal_px = focal_px;
  camera.calibrated = out->applied ? out->lens : calibrated;
  const std::optional<CameraIntrinsics> lens =
      RunLens(config, camera, out->width_px, out->height_px, reduced_focal_px);
  AttitudeEstimationOptions o;
  o.focal_px = reduced_focal_px;
  o.cx_px = (out->width_px - 1) / 2.0;
  o.cy_px = (out->height_px - 1) / 2.0;
  if (lens) {
    // The points in the undistorted pinhole camera (camera/lens.h LensUndistortion::output);
    // a point the lens model cannot undistort is dropped from its pair.
    const LensUndistortion undistortion(*lens);
    o.focal_px = undistortion.output().fx_px;
    o.cx_px = undistortion.output().cx_px;
    o.cy_px = undistortion.output().cy_px;
    for (LensPair& pair : pairs) {
      Eigen::Index kept = 0;
      for (Eigen::Index i = 0; i < pair.prev_px.cols(); ++i) {
        double pu = 0, pv = 0, cu = 0, cv = 0;
        if (!undistortion.UndistortPixel(pair.prev_px(0, i), pair.prev_px(1, i), &pu, &pv) ||
            !undistortion.UndistortPixel(pair.curr_px(0, i), pair.curr_px(1, i), &cu, &cv)) {
          continue;
        }
        pair.prev_px.col(kept) = Eigen::Vector2d(pu, pv);
        pair.curr_px.col(kept++) = Eigen::Vector2d(cu, cv);
      }
      pair.prev_px.conservativeResize(2, kept);
      pair.curr_px.conservativeResize(2, kept);
    }
  }
  o.width_px = out->width_px;
  o.height_px = out->height_px;
  o.seed = config.odometry.correspondence.ransac.seed;
  a.estimate = EstimateCameraAttitude(pairs, o);
  a.estimate_ms = sw.elapsed_ms();
  const AttitudeEstimate& e = *a.estimate;
  a.why = e.why;
  a.status = !e.valid          ? LensPrepassStatus::kNoEstimate
             : !e.significant  ? LensPrepassStatus::kNotSignificant
                               : LensPrepassStatus::kApplied;
  a.applied = e.significant;
}

// SURF and matching of the pre-pass's pairs: each frame reduced to the pre-pass's budget, the
// run's surf and match options.
class PairMatcher {
 public:
  PairMatcher(const RunConfig& config, int w, int h)
      : w_(w), h_(h), reducer_(w, h, kLensPrepassMegapixels), surf_(config.odometry.surf),
        matcher_(config.odometry.correspondence.match) {}
  int width_px() const { return reducer_.out_width_px(); }
  int height_px() const { return reducer_.out_height_px(); }
  /// InputError naming a frame of another size than the run's.
  LensPair Match(const Frame& prev, const Frame& curr) {
    const FeatureSet a = Features(prev);
    const FeatureSet b = Features(curr);
    return LensPairOf(a, b, matcher_.Match(a, b));
  }

 private:
  FeatureSet Features(const Frame& f) {
    if (f.gray.width() != w_ || f.gray.height() != h_) {
      throw InputError(fmt::format("{}: {}x{} px, but the run's frames are {}x{}", f.name,
                                   f.gray.width(), f.gray.height(), w_, h_));
    }
    return surf_.DetectAndDescribe(reducer_.Apply(f.gray.view())).features;
  }
  int w_, h_;
  FrameReducer reducer_;
  Surf surf_;
  Matcher matcher_;
};

// Marks the request's statuses "failed" with `why`; false.
bool Fail(const PrepassRequest& request, const std::string& why, LensPrepass* out) {
  if (request.lens) {
    out->status = LensPrepassStatus::kFailed;
    out->why = why;
  }
  if (request.attitude) {
    out->attitude.status = LensPrepassStatus::kFailed;
    out->attitude.why = why;
  }
  return false;
}

// Reads and matches the pairs into *pairs; false (out's statuses "failed", the reason in their
// why) on an input error.
bool ReadAndMatch(const RunConfig& config, int w, int h, const PrepassRequest& request,
                  std::vector<LensPair>* pairs, LensPrepass* out) {
  std::vector<std::pair<Frame, Frame>> frames;
  try {
    frames = ReadPairs(config, &out->read_ms, &out->why);
  } catch (const InputError& e) {
    return Fail(request, std::string("reading the frame pairs: ") + e.what(), out);
  }
  const Stopwatch match_sw;
  PairMatcher matcher(config, w, h);
  out->width_px = matcher.width_px();
  out->height_px = matcher.height_px();
  try {
    for (const auto& [prev, curr] : frames) {
      ThrowIfStopped();
      out->pair_frames.push_back(prev.index);
      pairs->push_back(matcher.Match(prev, curr));
    }
  } catch (const InputError& e) {
    return Fail(request, std::string("matching the frame pairs: ") + e.what(), out);
  }
  out->pairs_read = static_cast<int>(pairs->size());
  out->match_ms = match_sw.elapsed_ms();
  return true;
}

// The pairs of a live source as the feed hands them over, matched as they come, until it is
// closed; false (status "failed") on a frame of another size.
bool MatchFeed(const RunConfig& config, int w, int h, LivePairFeed& feed,
               std::vector<LensPair>* pairs, LensPrepass* out) {
  PairMatcher matcher(config, w, h);
  out->width_px = matcher.width_px();
  out->height_px = matcher.height_px();
  std::pair<Frame, Frame> pair;
  for (;;) {
    const Stopwatch wait_sw;
    if (!feed.Pop(&pair, t_stop)) break;
    out->read_ms += wait_sw.elapsed_ms();
    const Stopwatch match_sw;
    try {
      out->pair_frames.push_back(pair.first.index);
      pairs->push_back(matcher.Match(pair.first, pair.second));
    } catch (const InputError& e) {
      return Fail(PrepassRequest{}, std::string("matching the frame pairs: ") + e.what(), out);
    }
    out->match_ms += match_sw.elapsed_ms();
  }
  out->pairs_read = static_cast<int>(pairs->size());
  return true;
}

// The lens estimated from a live source's pairs (LensPrepassTask with a feed).
LensPrepass RunLivePrepass(const RunConfig& config, int w, int h, double focal_px,
                           LivePairFeed& feed) {
  const Stopwatch total;
  LensPrepass out;
  std::vector<LensPair> pairs;
  if (MatchFeed(config, w, h, feed, &pairs, &out)) {
    EstimateLens(config, pairs, w, h, focal_px, focal_px * out.width_px / w, &out);
  }
  out.total_ms = total.elapsed_ms();
  return out;
}

}  // namespace

LensPrepass RunLensPrepass(const RunConfig& config, int w, int h, double focal_px,
                           const PrepassRequest& request) {
  if (w <= 0 || h <= 0 || !(focal_px > 0.0) || !std::isfinite(focal_px)) {
    throw InvalidArgument(fmt::format("RunLensPrepass: frames {}x{}, focal {} px", w, h, focal_px));
  }
  const Stopwatch total;
  LensPrepass out;
  std::vector<LensPair> pairs;
  if (ReadAndMatch(config, w, h, request, &pairs, &out)) {
    const double reduced_focal_px = focal_px * out.width_px / w;
    if (request.lens) EstimateLens(config, pairs, w, h, focal_px, reduced_focal_px, &out);
    if (request.attitude) {
      EstimateAttitude(config, std::move(pairs), focal_px, reduced_focal_px, request.calibrated,
                       &out);
    }
  }
  out.total_ms = total.elapsed_ms();
  return out;
}

void LivePairFeed::Push(Frame prev, Frame curr) {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (closed_) return;
    pairs_.emplace_back(std::move(prev), std::move(curr));
  }
  ready_.notify_one();
}

void LivePairFeed::Close() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    closed_ = true;
  }
  ready_.notify_one();
}

bool LivePairFeed::Pop(std::pair<Frame, Frame>* pair, const std::atomic<bool>* stop) {
  std::unique_lock<std::mutex> lock(mutex_);
  while (pairs_.empty() && !closed_) {
    if (stop != nullptr && stop->load()) throw Cancelled("waiting for the live frame pairs");
    ready_.wait_for(lock, std::chrono::milliseconds(20));
  }
  if (pairs_.empty()) return false;
  *pair = std::move(pairs_.front());
  pairs_.pop_front();
  return true;
}

LensPrepassTask::LensPrepassTask(const RunConfig& config, int w, int h, double focal_px,
                                 const std::atomic<bool>* stop,
                                 std::shared_ptr<LivePairFeed> live_feed)
    : result_(std::async(std::launch::async, [&config, w, h, focal_px, stop, live_feed] {
        t_stop = stop;
        try {
          if (live_feed) return RunLivePrepass(config, w, h, focal_px, *live_feed);
          return RunLensPrepass(config, w, h, focal_px);
        } catch (const Cancelled& e) {
          LensPrepass out;
          out.status = LensPrepassStatus::kFailed;
          out.why = std::string("stopped: ") + e.what();
          return out;
        }
      })) {}

LensPrepassTask::~LensPrepassTask() {
  if (result_.valid()) result_.wait();
}

bool LensPrepassTask::Ready() const {
  return result_.valid() && result_.wait_for(std::chrono::seconds(0)) == std::future_status::ready;
}

LensPrepass LensPrepassTask::Get(const std::atomic<bool>* stop, double* waited_ms) {
  if (taken_) throw InvalidArgument("LensPrepassTask::Get: called twice");
  const Stopwatch sw;
  while (result_.wait_for(std::chrono::milliseconds(20)) != std::future_status::ready) {
    if (stop != nullptr && stop->load()) throw Cancelled("waiting for the lens estimate");
  }
  if (waited_ms != nullptr) *waited_ms = sw.elapsed_ms();
  taken_ = true;  // not before: a Get() cancelled while waiting can be called again
  return result_.get();
}

nlohmann::json ToJson(const LensPrepass& p) {
  nlohmann::json j{{"status", ToString(p.status)}, {"applied", p.applied}, {"why", p.why}};
  if (p.status == LensPrepassStatus::kSkipped) return j;
  j["pairs_read"] = p.pairs_read;
  j["pair_frames"] = p.pair_frames;
  j["frame_width_px"] = p.width_px;
  j["frame_height_px"] = p.height_px;
  j["time_ms"] = {{"read", p.read_ms},
                  {"match", p.match_ms},
                  {"estimate", p.estimate_ms},
                  {"total", p.total_ms}};
  if (p.estimate) {
    const LensEstimate& e = *p.estimate;
    j["family"] = ToString(e.family);
    j["k"] = e.k;
    j["sigma_k"] = e.sigma_k;
    j["cost_drop"] = e.cost_drop;
    j["cost"] = e.cost;
    j["cost_pinhole"] = e.cost_pinhole;
    j["median_residual_px"] = e.median_residual_px;
    j["median_residual_pinhole_px"] = e.median_residual_pinhole_px;
    j["pairs_used"] = e.pairs_used;
    j["pairs_improved"] = e.pairs_improved;
    j["pair_fraction_improved"] =
        e.pairs_used > 0 ? static_cast<double>(e.pairs_improved) / e.pairs_used : 0.0;
    j["points_used"] = e.points_used;
    j["pair_k"] = e.pair_k;
  }
  if (p.applied) j["file"] = kLensEstimateYaml;
  return j;
}


nlohmann::json ToJson(const AttitudePrepass& a) {
  nlohmann::json j{{"status", ToString(a.status)}, {"applied", a.applied}, {"why", a.why}};
  if (!a.estimate) return j;
  const AttitudeEstimate& e = *a.estimate;
  j["pairs_used"] = e.pairs_used;
  j["points_used"] = e.points_used;
  j["time_ms"] = a.estimate_ms;
  if (!e.valid) return j;  // no attitude to report (too few pairs with motion)
  j["roll_deg"] = e.attitude.roll_deg;
  j["pitch_deg"] = e.attitude.pitch_deg;
  j["tilt_deg"] = e.tilt_deg;
  j["sigma_roll_deg"] = e.sigma_roll_deg;
  j["sigma_pitch_deg"] = e.sigma_pitch_deg;
  j["cost_drop"] = e.cost_drop;
  j["cost"] = e.cost;
  j["cost_nadir"] = e.cost_nadir;
  j["median_residual_px"] = e.median_residual_px;
  j["median_residual_nadir_px"] = e.median_residual_nadir_px;
  j["pairs_improved"] = e.pairs_improved;
  std::vector<double> rolls, pitches;
  for (const CameraAttitude& p : e.pair_attitude) {
    rolls.push_back(p.roll_deg);
    pitches.push_back(p.pitch_deg);
  }
  j["pair_roll_deg"] = rolls;
  j["pair_pitch_deg"] = pitches;
  return j;
}

}  // namespace aerovo::run_steps
