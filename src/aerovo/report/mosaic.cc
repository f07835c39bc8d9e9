#include "aerovo/report/mosaic.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <optional>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/camera_files/calibration.h"
#include "aerovo/core/error.h"
#include "aerovo/core/options_json.h"
#include "aerovo/frames/camera.h"
#include "aerovo/frames/frame_source.h"
#include "aerovo/imageio/image_io.h"
#include "aerovo/odometry/attitude.h"
#include "aerovo/outputs/track_writers.h"
#include "aerovo/report/mosaic_warp.h"

namespace aerovo {
namespace fs = std::filesystem;

void Validate(const MosaicOptions& o) {
  if (o.max_size_px < 100 || o.max_size_px > 20000) {
    throw InvalidArgument("mosaic: max_size_px must be within 100..20000");
  }
  if (o.max_frames < 1) throw InvalidArgument("mosaic: max_frames must be >= 1");
  if (o.jpeg_quality < 1 || o.jpeg_quality > 100) {
    throw InvalidArgument("mosaic: jpeg_quality must be within 1..100");
  }
}

namespace {

cv::Matx23d ToMatx(const FrameTransformRow& t) {
  return cv::Matx23d(t.a[0], t.a[1], t.a[2], t.a[3], t.a[4], t.a[5]);
}

cv::Point2d Apply(const cv::Matx23d& m, double x, double y) {
  return {m(0, 0) * x + m(0, 1) * y + m(0, 2), m(1, 0) * x + m(1, 1) * y + m(1, 2)};
}

bool FrameSize(const RunData& run, int* w, int* h) {
  if (!run.config.is_object() || !run.config.contains("resolved")) return false;
  const nlohmann::json& r = run.config["resolved"];
  if (!r.contains("frame_width_px") || !r.contains("frame_height_px")) return false;
  const std::optional<int> width = options::JsonValueIn<int>(r["frame_width_px"], 1, 1000000),
                           height = options::JsonValueIn<int>(r["frame_height_px"], 1, 1000000);
  if (!width || !height) return false;
  *w = *width;
  *h = *height;
  return true;
}

// The run's configuration value `key` (config.json), or `fallback` when absent, null, of another
// type or, for a number, outside [lo, hi] (a config.json that outside data may have replaced).
template <class T>
T ConfigValue(const nlohmann::json& c, const char* key, T fallback,
              T lo = std::numeric_limits<T>::lowest(), T hi = std::numeric_limits<T>::max()) {
  if (!c.is_object() || !c.contains(key) || c[key].is_null()) return fallback;
  return options::JsonValueIn<T>(c[key], lo, hi).value_or(fallback);
}

// The input as given to `aerovo run` (relative to where it ran, or to the run folder); an empty
// string when it is readable, else the reason.
std::string InputPath(const RunData& run, fs::path* input_path);

cv::Scalar Bgr(unsigned rgb) {
  return cv::Scalar(rgb & 0xff, (rgb >> 8) & 0xff, (rgb >> 16) & 0xff);
}

std::string InputPath(const RunData& run, fs::path* input_path) {
  const std::string input = ConfigValue<std::string>(run.config, "input", "");
  *input_path = input;
  if (!input.empty() && !fs::exists(*input_path) && input_path->is_relative() &&
      fs::exists(run.dir / *input_path)) {
    *input_path = run.dir / *input_path;
  }
  std::error_code ec;
  if (input.empty() ||
      !(fs::is_regular_file(*input_path, ec) || fs::is_directory(*input_path, ec))) {
    return "the run's input '" + input + "' is not readable any more (or is a live source)";
  }
  return "";
}

}  // namespace

bool MosaicFrameSize(const RunData& run, int* width_px, int* height_px) {
  return FrameSize(run, width_px, height_px);
}

bool RecordsCameraAttitude(const RunData& run) { return run.records_camera_attitude; }

Eigen::Matrix3d MosaicNadirFromFrame(const RunData& run, int width_px, int height_px,
                                     int frame) {
  const Eigen::Matrix3d identity = Eigen::Matrix3d::Identity();
  const double focal_px = run.config.is_object() && run.config.contains("resolved")
                              ? ConfigValue<double>(run.config["resolved"], "focal_px", 0.0)
                              : 0.0;
  if (!(focal_px > 0.0)) return identity;
  std::optional<CameraAttitude> attitude;
  if (RecordsCameraAttitude(run)) {
    // frames.csv is in frame order: the frame's row, its attitude or none.
    const auto it = std::lower_bound(
        run.frames.begin(), run.frames.end(), frame,
        [](const RunFrameRow& f, int index) { return f.frame < index; });
    if (it != run.frames.end() && it->frame == frame && it->camera_roll_deg &&
        it->camera_pitch_deg) {
      attitude = CameraAttitude{*it->camera_roll_deg, *it->camera_pitch_deg};
    }
  } else if (run.summary.is_object() && run.summary.contains("attitude_estimate")) {
    // A run folder without the columns: the flight's estimate, when applied to every frame.
    const nlohmann::json& a = run.summary["attitude_estimate"];
    if (a.is_object() && a.value("applied", false) && a.contains("roll_deg") &&
        a.contains("pitch_deg") && a["roll_deg"].is_number() && a["pitch_deg"].is_number()) {
      attitude = CameraAttitude{a["roll_deg"].get<double>(), a["pitch_deg"].get<double>()};
    }
  }
  if (!attitude) return identity;
  return NadirFromCameraHomography(*attitude, focal_px, 0.5 * (width_px - 1),
                                   0.5 * (height_px - 1));
}

const std::vector<FrameTransformRow>& MosaicPlacements(const RunData& run,
                                                       const MosaicOptions& options) {
  const bool use = options.optimized && !run.transforms_optimized.empty() &&
                   run.transforms_optimized.size() == run.transforms.size();
  return use ? run.transforms_optimized : run.transforms;
}

std::vector<Eigen::Vector2d> FrameCentresPx(const RunData& run, std::vector<int>* frames,
                                            const std::vector<FrameTransformRow>* rows) {
  std::vector<Eigen::Vector2d> out;
  int w = 0, h = 0;
  if (!FrameSize(run, &w, &h)) return out;
  const double cx = 0.5 * (w - 1), cy = 0.5 * (h - 1);
  for (const FrameTransformRow& t : rows != nullptr ? *rows : run.transforms) {
    const cv::Point2d p = Apply(ToMatx(t), cx, cy);
    out.emplace_back(p.x, p.y);
    if (frames) frames->push_back(t.frame);
  }
  return out;
}

std::string MosaicInputProblem(const RunData& run) {
  int w = 0, h = 0;
  if (run.transforms.empty()) {
    return "the run has no transforms.csv (written by aerovo run since the report was added)";
  }
  if (!FrameSize(run, &w, &h)) return "config.json does not give the frame size";
  fs::path input_path;
  return InputPath(run, &input_path);
}

MosaicWarpOutcome WarpRunFrames(const RunData& run, const MosaicOptions& options,
                                std::vector<MosaicWarpTarget>& targets) {
  MosaicWarpOutcome out;
  const std::vector<FrameTransformRow>& placements = MosaicPlacements(run, options);
  out.n_transforms = static_cast<int>(placements.size());
  if (std::string problem = MosaicInputProblem(run); !problem.empty()) {
    out.note = problem;
    return out;
  }
  int w = 0, h = 0;
  FrameSize(run, &w, &h);
  fs::path input_path;
  InputPath(run, &input_path);
  std::map<int, cv::Matx23d> by_frame;
  for (const FrameTransformRow& t : placements) by_frame[t.frame] = ToMatx(t);

  const int n_transforms = out.n_transforms;
  const int every = std::max(1, (n_transforms + options.max_frames - 1) / options.max_frames);
  out.every_nth = every;
  FrameSourceOptions so;
  // The ranges of the run's options (pipeline/run_config.h).
  so.step = static_cast<int>(
      std::min<long long>(1LL * ConfigValue<int>(run.config, "step", 1, 1, 1000000) * every,
                          std::numeric_limits<int>::max()));
  so.start_time_s = ConfigValue<double>(run.config, "start_s", 0.0);
  const double end_s = ConfigValue<double>(run.config, "end_s", -1.0);
  if (end_s >= 0.0) so.end_time_s = end_s;
  so.photo_gap_s = ConfigValue<double>(run.config, "photo_gap_s", so.photo_gap_s);
  so.photo_flight = ConfigValue<int>(run.config, "photo_flight", so.photo_flight, -1, 1000000);
  so.photo_band = ConfigValue<std::string>(run.config, "photo_band", "");
  // The run's video decoder (an unknown name: the default).
  so.video_decoder =
      options::ParseEnum<VideoDecoderChoice>(ConfigValue<std::string>(run.config, "video_decoder",
                                                                      "auto"))
          .value_or(VideoDecoderChoice::kAuto);
  so.video_threads = ConfigValue<int>(run.config, "video_threads", so.video_threads, 0, 64);
  so.keep_color = true;
  // Lens distortion, as the run applied it before SURF (pipeline/preprocess.h FrameUndistorter):
  // the same camera and the same maps (frames/camera.h Undistorter).
  const double k1 = ConfigValue<double>(run.config, "k1", 0.0),
               k2 = ConfigValue<double>(run.config, "k2", 0.0),
               p1 = ConfigValue<double>(run.config, "p1", 0.0),
               p2 = ConfigValue<double>(run.config, "p2", 0.0),
               k3 = ConfigValue<double>(run.config, "k3", 0.0);
  const double focal_px = run.config.contains("resolved")
                              ? ConfigValue<double>(run.config["resolved"], "focal_px", 0.0)
                              : 0.0;
  std::optional<Undistorter> undistorter;
  if ((k1 != 0.0 || k2 != 0.0 || p1 != 0.0 || p2 != 0.0 || k3 != 0.0) && focal_px > 0.0) {
    CameraIntrinsics k = IntrinsicsFromFocalPx(focal_px, w, h);
    k.distortion = {k1, k2, p1, p2, k3};
    undistorter.emplace(k);
  }
  // A calibration file (run option calibration): the run's camera, scaled to the frames.
  const std::string calibration = ConfigValue<std::string>(run.config, "calibration", "");
  if (!calibration.empty()) {
    undistorter.emplace(ScaledTo(ReadCalibration(calibration).intrinsics, w, h));
  }
  // The run's lens self-calibration, when it was applied (pipeline/lens_prepass.h).
  const std::filesystem::path estimate = run.dir / RunFileNames::kLensEstimateYaml;
  if (calibration.empty() && run.summary.is_object() && run.summary.contains("lens_estimate") &&
      run.summary["lens_estimate"].is_object() &&
      run.summary["lens_estimate"].value("applied", false) && std::filesystem::exists(estimate)) {
    undistorter.emplace(ScaledTo(ReadCalibration(estimate.string()).intrinsics, w, h));
  }
  // The run saw the frames dimmed by illumination_k (illumination experiment): so does the mosaic.
  const double illumination_k = ConfigValue<double>(run.config, "illumination_k", 1.0);
  const int last_frame = placements.back().frame;
  try {
    std::unique_ptr<FrameSource> source = OpenFrameSource(input_path.string(), so);
    Frame frame;
    cv::Mat small, warped, mask, ones;
    while (source->Next(frame)) {
      if (frame.index > last_frame) break;
      const auto it = by_frame.find(frame.index);
      if (it == by_frame.end()) continue;
      cv::Mat color = frame.color;
      if (color.empty()) continue;
      if (color.cols != w || color.rows != h) continue;  // not the run's frame size
      if (undistorter) {
        cv::Mat u;
        undistorter->Apply(color, u);
        color = u;
      }
      if (illumination_k > 0.0 && illumination_k < 1.0) {
        cv::Mat dimmed;
        color.convertTo(dimmed, -1, illumination_k, 0.0);
        color = dimmed;
      }
      const cv::Matx23d& a = it->second;
      // The frame to the virtual nadir camera the transforms place (the attitude the run applied).
      const Eigen::Matrix3d nadir = MosaicNadirFromFrame(run, w, h, frame.index);
      const cv::Matx33d nadir_from_frame(nadir(0, 0), nadir(0, 1), nadir(0, 2), nadir(1, 0),
                                         nadir(1, 1), nadir(1, 2), nadir(2, 0), nadir(2, 1),
                                         nadir(2, 2));
      const cv::Matx33d first_from_frame(a(0, 0), a(0, 1), a(0, 2), a(1, 0), a(1, 1), a(1, 2), 0,
                                         0, 1);
      bool drawn = false;
      for (MosaicWarpTarget& target : targets) {
        const cv::Matx23d& c = target.canvas_from_first;
        const cv::Matx33d canvas_from_first(c(0, 0), c(0, 1), c(0, 2), c(1, 0), c(1, 1), c(1, 2),
                                            0, 0, 1);
        cv::Matx33d m = canvas_from_first * first_from_frame * nadir_from_frame;
        const int cw = target.bgr.cols, ch = target.bgr.rows;
        // Downscale first (area averaging) when the frame shrinks a lot on the canvas: faster
        // and without aliasing.
        const double lin = std::sqrt(std::abs(m(0, 0) * m(1, 1) - m(0, 1) * m(1, 0)));
        if (!(lin > 0.0) || !std::isfinite(lin)) continue;
        double f = 1.0;
        if (lin < 0.5) {
          f = std::max(lin, 4.0 / std::min(w, h));
          cv::resize(color, small, cv::Size(), f, f, cv::INTER_AREA);
          m = m * cv::Matx33d(1.0 / f, 0, 0, 0, 1.0 / f, 0, 0, 0, 1);
        } else {
          small = color;
        }
        // Warp into the frame's bounding box on the canvas only.
        double bx0 = 1e300, by0 = 1e300, bx1 = -1e300, by1 = -1e300;
        for (const cv::Point2d c :
             {cv::Point2d(0, 0), cv::Point2d(small.cols - 1, 0),
              cv::Point2d(small.cols - 1, small.rows - 1), cv::Point2d(0, small.rows - 1)}) {
          const double z = m(2, 0) * c.x + m(2, 1) * c.y + m(2, 2);
          const double x = (m(0, 0) * c.x + m(0, 1) * c.y + m(0, 2)) / z;
          const double y = (m(1, 0) * c.x + m(1, 1) * c.y + m(1, 2)) / z;
          bx0 = std::min(bx0, x);
          by0 = std::min(by0, y);
          bx1 = std::max(bx1, x);
          by1 = std::max(by1, y);
        }
        if (!std::isfinite(bx0) || !std::isfinite(by0) || !std::isfinite(bx1) ||
            !std::isfinite(by1) || bx1 < -1.0 || by1 < -1.0 || bx0 > cw || by0 > ch) {
          continue;
        }
        const cv::Rect box =
            cv::Rect(cv::Point(static_cast<int>(std::floor(std::max(bx0, -1.0))),
                               static_cast<int>(std::floor(std::max(by0, -1.0)))),
                     cv::Point(static_cast<int>(std::ceil(std::min<double>(bx1, cw))) + 1,
                               static_cast<int>(std::ceil(std::min<double>(by1, ch))) + 1)) &
            cv::Rect(0, 0, cw, ch);
        if (box.area() <= 0) continue;
        const cv::Matx33d roi_from_frame =
            cv::Matx33d(1, 0, -box.x, 0, 1, -box.y, 0, 0, 1) * m;
        cv::warpPerspective(small, warped, roi_from_frame, box.size(), cv::INTER_LINEAR,
                            cv::BORDER_CONSTANT);
        ones = cv::Mat(small.size(), CV_8UC1, cv::Scalar(255));
        cv::warpPerspective(ones, mask, roi_from_frame, box.size(), cv::INTER_NEAREST,
                            cv::BORDER_CONSTANT);
        cv::erode(mask, mask, cv::Mat());  // no dark seam from the interpolated border
        warped.copyTo(target.bgr(box), mask);
        if (!target.coverage.empty()) target.coverage(box).setTo(255, mask);
        drawn = true;
      }
      if (drawn) ++out.frames_used;
    }
  } catch (const InputError& e) {
    out.note = std::string("cannot re-read the input: ") + e.what();
    return out;
  }
  if (out.frames_used == 0) {
    out.note = "no frame of the input matched the run's transforms";
    return out;
  }
  out.ok = true;
  return out;
}

MosaicResult BuildMosaic(const RunData& run, const std::vector<MosaicTrack>& tracks,
                         const fs::path& out_file, const MosaicOptions& options) {
  Validate(options);
  MosaicResult result;
  int w = 0, h = 0;
  if (std::string problem = MosaicInputProblem(run); !problem.empty()) {
    result.note = "no mosaic: " + problem;
    return result;
  }
  FrameSize(run, &w, &h);

  // Bounds of every frame in first-frame pixels, and of the tracks.
  double min_x = std::numeric_limits<double>::infinity(), min_y = min_x;
  double max_x = -min_x, max_y = -min_x;
  auto grow = [&](double x, double y) {
    if (!std::isfinite(x) || !std::isfinite(y)) return;
    min_x = std::min(min_x, x);
    min_y = std::min(min_y, y);
    max_x = std::max(max_x, x);
    max_y = std::max(max_y, y);
  };
  for (const FrameTransformRow& t : MosaicPlacements(run, options)) {
    const Eigen::Matrix3d nadir_from_frame = MosaicNadirFromFrame(run, w, h, t.frame);
    const cv::Matx23d m = ToMatx(t);
    for (const cv::Point2d c : {cv::Point2d(0, 0), cv::Point2d(w - 1, 0), cv::Point2d(w - 1, h - 1),
                                cv::Point2d(0, h - 1)}) {
      const Eigen::Vector3d q = nadir_from_frame * Eigen::Vector3d(c.x, c.y, 1.0);
      const cv::Point2d p = Apply(m, q.x() / q.z(), q.y() / q.z());
      grow(p.x, p.y);
    }
  }
  for (const MosaicTrack& tr : tracks) {
    for (const Eigen::Vector2d& p : tr.points_px) grow(p.x(), p.y());
  }
  const double margin = 0.02 * std::max(max_x - min_x, max_y - min_y);
  min_x -= margin;
  min_y -= margin;
  max_x += margin;
  max_y += margin;
  const double span = std::max(max_x - min_x, max_y - min_y);
  if (!(span > 0.0) || !std::isfinite(span)) {
    result.note = "no mosaic: the transforms are degenerate";
    return result;
  }
  const double s = std::min(1.0, options.max_size_px / span);
  const int cw = std::max(16, static_cast<int>(std::ceil((max_x - min_x) * s)));
  const int ch = std::max(16, static_cast<int>(std::ceil((max_y - min_y) * s)));
  std::vector<MosaicWarpTarget> targets(1);
  targets[0].canvas_from_first = cv::Matx23d(s, 0, -s * min_x, 0, s, -s * min_y);
  targets[0].bgr = cv::Mat(ch, cw, CV_8UC3, cv::Scalar(255, 255, 255));
  const MosaicWarpOutcome warp = WarpRunFrames(run, options, targets);
  if (!warp.ok) {
    result.note = "no mosaic: " + warp.note;
    return result;
  }
  cv::Mat& canvas = targets[0].bgr;
  result.frames_used = warp.frames_used;
  result.every_nth = warp.every_nth;
  const int n_transforms = warp.n_transforms;
  const int every = warp.every_nth;
  std::error_code ec;

  // Tracks (in order: later ones on top, each over a white halo), then a legend box.
  const double size_k = std::max(cw, ch) / 1000.0;  // line widths scale with the mosaic
  const int lw = std::max(1, static_cast<int>(std::lround(size_k)));
  auto thickness_of = [&](const MosaicTrack& tr) {
    return std::max(2, static_cast<int>(std::lround(tr.line_width_px * size_k)));
  };
  std::vector<std::vector<cv::Point>> polylines;  // 4 fractional bits
  for (const MosaicTrack& tr : tracks) {
    std::vector<cv::Point> pts;
    for (const Eigen::Vector2d& p : tr.points_px) {
      const double x = s * (p.x() - min_x), y = s * (p.y() - min_y);
      if (!std::isfinite(x) || !std::isfinite(y)) continue;
      pts.emplace_back(static_cast<int>(std::lround(x * 16)),
                       static_cast<int>(std::lround(y * 16)));
    }
    polylines.push_back(std::move(pts));
  }
  for (std::size_t i = 0; i < tracks.size(); ++i) {  // halos first: lines never hide each other
    if (polylines[i].empty()) continue;
    cv::polylines(canvas, polylines[i], false, cv::Scalar(255, 255, 255),
                  thickness_of(tracks[i]) + 2 * lw, cv::LINE_AA, 4);
  }
  for (std::size_t i = 0; i < tracks.size(); ++i) {
    if (polylines[i].empty()) continue;
    const int thickness = thickness_of(tracks[i]);
    cv::polylines(canvas, polylines[i], false, Bgr(tracks[i].color_rgb), thickness, cv::LINE_AA, 4);
    cv::circle(canvas, polylines[i].front(), 16 * (thickness + lw), Bgr(tracks[i].color_rgb),
               cv::FILLED, cv::LINE_AA, 4);
  }
  const double font = 0.35 * lw + 0.25;
  const int line_h = static_cast<int>(28 * font) + 6;
  int legend_w = 0;
  for (const MosaicTrack& tr : tracks) {
    int base = 0;
    legend_w = std::max(
        legend_w,
        cv::getTextSize(tr.name, cv::FONT_HERSHEY_SIMPLEX, font, std::max(1, lw), &base).width);
  }
  if (!tracks.empty()) {
    const int pad = 8 * lw;
    const cv::Rect legend(pad, pad, legend_w + 3 * pad + 40 * lw,
                          static_cast<int>(tracks.size()) * line_h + pad);
    cv::rectangle(canvas, legend & cv::Rect(0, 0, cw, ch), cv::Scalar(255, 255, 255), cv::FILLED);
    cv::rectangle(canvas, legend & cv::Rect(0, 0, cw, ch), cv::Scalar(80, 80, 80), 1);
    for (std::size_t i = 0; i < tracks.size(); ++i) {
      const int y = legend.y + pad / 2 + static_cast<int>(i) * line_h + line_h / 2;
      cv::line(canvas, {legend.x + pad, y}, {legend.x + pad + 40 * lw, y}, Bgr(tracks[i].color_rgb),
               thickness_of(tracks[i]), cv::LINE_AA);
      cv::putText(canvas, tracks[i].name, {legend.x + 2 * pad + 40 * lw, y + line_h / 3},
                  cv::FONT_HERSHEY_SIMPLEX, font, cv::Scalar(0, 0, 0), std::max(1, lw),
                  cv::LINE_AA);
    }
  }
  std::vector<int> params;
  std::string ext = out_file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  if (ext == ".jpg" || ext == ".jpeg") params = {cv::IMWRITE_JPEG_QUALITY, options.jpeg_quality};
  fs::create_directories(out_file.parent_path(), ec);
  bool ok = false;
  try {
    ok = imageio::Write(out_file.string(), canvas, params);
  } catch (const cv::Exception& e) {
    throw InputError("cannot write the mosaic '" + out_file.string() + "': " + e.what());
  }
  if (!ok) throw InputError("cannot write the mosaic '" + out_file.string() + "'");
  result.written = true;
  result.optimized = &MosaicPlacements(run, options) == &run.transforms_optimized;
  result.file = out_file;
  result.width_px = cw;
  result.height_px = ch;
  result.scale = s;
  result.note =
      fmt::format("{} of {} frames warped ({}), {}x{} px, {:.3f} mosaic px per first-frame px{}",
                  result.frames_used, n_transforms,
                  every == 1 ? std::string("all") : fmt::format("one in {}", every), cw, ch, s,
                  result.optimized ? ", placed by the optimised poses" : "");
  return result;
}

}  // namespace aerovo
