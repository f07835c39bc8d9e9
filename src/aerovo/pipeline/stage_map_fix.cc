// The map-fix stage and sink (RunConfig::map; pipeline/map_fixer.h): every
// map_fix.every_n_frames-th frame processed, once the track is geo-referenced, is handed to
// the run's MapFixer with its prediction: the track's WGS84 position (GeoReferencer::
// Wgs84FromLocal of the odometry's position) and ENU heading (the odometry's heading plus
// GeoReferencer::rotation_rad), its height above ground, the processed frame's focal length
// and the frame's GPS (withheld or not) for the comparison. After the georeference stage, so
// that the frame that fixes the geo-reference is predicted already. The sink's End waits for
// the last attempt and writes map_fixes.csv and summary.json "map_fixes".
#include <memory>
#include <utility>

#include "aerovo/pipeline/frame_loop.h"
#include "aerovo/pipeline/map_fixer.h"

namespace aerovo::run_steps {
namespace {

class MapFixStage : public FrameStage {
 public:
  const char* name() const override { return "map_fix"; }

  void Process(FrameState& f, const RunContext& run) override {
    MapFixer& fixer = *run.map_fixer;
    if (!fixer.Due(processed_++)) return;
    const GeoReferencer& georef = run.state->georef;
    const double focal_px = run.vo_options.focal_px;
    if (!georef.ready() || f.pixels.empty() || !(f.height_m > 0.0) || !(focal_px > 0.0)) {
      fixer.CountNoPrediction();
      return;
    }
    MapFixJob job;
    job.frame = f.frame.index;
    job.time_s = f.frame.time_s;
    job.pixels = GrayImage(f.pixels.width, f.pixels.height);
    for (int y = 0; y < f.pixels.height; ++y) {
      std::copy_n(f.pixels.row(y), f.pixels.width, job.pixels.row(y));
    }
    job.focal_px = focal_px;
    job.height_m = f.height_m;
    job.heading_rad = f.result.heading_rad + georef.rotation_rad();
    job.predicted = georef.Wgs84FromLocal(f.result.position_m);
    job.gps = f.gps ? f.gps : f.withheld_gps;
    fixer.Submit(std::move(job));
  }

 private:
  int processed_ = 0;  // frames seen by this stage
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
