// The map-fix stage and sink (RunConfig::map; pipeline/map_fixer.h): every
// map_fix.every_n_frames-th frame processed, once the track is geo-referenced, is handed to
// the run's MapFixer with its prediction: the track's WGS84 position (GeoReferencer::
// Wgs84FromLocal of the odometry's position) and ENU heading (the odometry's heading plus
// GeoReferencer::rotation_rad), its height above ground, the processed frame's focal length
// and the frame's GPS (withheld or not) for the comparison. After the georeference stage, so
// that the frame that fixes the geo-reference is predicted already. The sink's End waits for
// the last attempt and writes map_fixes.csv and summary.json "map_fixes".
// With map_fix.apply, a fix moves the track: from the frame it is taken at (MapFixer::TakeFix:
// a file source's next due frame, a live source's first frame after it is done) every frame's
// odometry position (FrameResult::position_m, local frame) is shifted by the sum of the fixes'
// differences from their predictions, rotated into the local frame; every output after this
// stage (frames.csv, the tracks, the pose stream, MAVLink, the comparisons) carries it.
#include <cmath>
#include <memory>
#include <optional>
#include <utility>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/odometry/attitude.h"
#include "aerovo/pipeline/frame_loop.h"
#include "aerovo/pipeline/map_fixer.h"

namespace aerovo::run_steps {
namespace {

// The frame's pixels as the virtual nadir camera with the same centre and focal length sees them
// (odometry/attitude.h NadirFromCameraHomography with the attitude the odometry applied, principal
// point at the centre): the map fixer takes the frame's centre for the ground point under the
// camera (odometry/map_match.h), as the odometry's keypoints, mapped through the same homography,
// do. A frame without an applied attitude is copied as it is; pixels outside the tilted frame
// are 0.
GrayImage NadirPixels(const FrameState& f, double focal_px) {
  const int w = f.pixels.width, h = f.pixels.height;
  GrayImage out(w, h);
  const cv::Mat src(h, w, CV_8UC1, const_cast<std::uint8_t*>(f.pixels.data),
                    static_cast<std::size_t>(f.pixels.stride));
  cv::Mat dst(h, w, CV_8UC1, out.data());
  if (!f.attitude.camera) {
    src.copyTo(dst);
    return out;
  }
  const Eigen::Matrix3d m =
      NadirFromCameraHomography(*f.attitude.camera, focal_px, 0.5 * (w - 1), 0.5 * (h - 1));
  const cv::Matx33d nadir_from_frame(m(0, 0), m(0, 1), m(0, 2), m(1, 0), m(1, 1), m(1, 2),
                                     m(2, 0), m(2, 1), m(2, 2));
  cv::warpPerspective(src, dst, nadir_from_frame, dst.size(), cv::INTER_LINEAR,
                      cv::BORDER_CONSTANT, cv::Scalar(0));
  return out;
}

class MapFixStage : public FrameStage {
 public:
  const char* name() const override { return "map_fix"; }

  void Process(FrameState& f, const RunContext& run) override {
    MapFixer& fixer = *run.map_fixer;
    const bool due = fixer.Due(processed_++);
    const GeoReferencer& georef = run.state->georef;
    if (fixer.options().apply && georef.ready()) Apply(fixer.TakeFix(due), georef);
    f.result.position_m += offset_local_m_;
    if (!due) return;
    const double focal_px = run.vo_options.focal_px;
    if (!georef.ready() || f.pixels.empty() || !(f.height_m > 0.0) || !(focal_px > 0.0)) {
      fixer.CountNoPrediction();
      return;
    }
    MapFixJob job;
    job.frame = f.frame.index;
    job.time_s = f.frame.time_s;
    job.pixels = NadirPixels(f, focal_px);
    job.focal_px = focal_px;
    job.height_m = f.height_m;
    job.heading_rad = f.result.heading_rad + georef.rotation_rad();
    job.predicted = georef.Wgs84FromLocal(f.result.position_m);
    job.gps = f.gps ? f.gps : f.withheld_gps;
    fixer.Submit(std::move(job));
  }

 private:
  // Adds `fix`'s difference from its prediction (the run's ENU, rotated into the local frame)
  // to the offset.
  void Apply(const std::optional<MapFixRecord>& fix, const GeoReferencer& georef) {
    if (!fix || !fix->geo) return;
    const LocalEnu& enu = georef.enu();
    const Eigen::Vector2d delta_enu =
        (enu.Forward(*fix->geo) - enu.Forward(fix->predicted)).head<2>();
    const double c = std::cos(georef.rotation_rad()), s = std::sin(georef.rotation_rad());
    offset_local_m_ += Eigen::Vector2d(c * delta_enu.x() + s * delta_enu.y(),
                                       -s * delta_enu.x() + c * delta_enu.y());
  }

  int processed_ = 0;                                         // frames seen by this stage
  Eigen::Vector2d offset_local_m_ = Eigen::Vector2d::Zero();  // the applied fixes' sum
};

class MapFixSink : public FrameSink {
 public:
  const char* name() const override { return "map_fix"; }
  void Write(FrameState&, const RunContext&) override {}
  void End(const LoopEnd&, const RunContext* run) override {
    if (run == nullptr || !run->map_fixer) return;
    try {
      run->map_fixer->Finish(run->out_dir, run->summary);
    } catch (const Error& e) {  // the last attempt's map read, or map_fixes.csv's write
      run->summary->warnings.push_back(std::string("map fixes: ") + e.what());
    }
  }
};

}  // namespace

std::unique_ptr<FrameStage> MakeMapFixStage() { return std::make_unique<MapFixStage>(); }
std::unique_ptr<FrameSink> MakeMapFixSink() { return std::make_unique<MapFixSink>(); }

}  // namespace aerovo::run_steps
