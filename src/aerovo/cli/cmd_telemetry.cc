// `aerovo telemetry`: reads a telemetry source (DJI .srt, .gpx, .csv, an ArduPilot .bin/.log, a
// PX4 .ulg, a MAVLink .tlog, a photo or a folder of photos) the way `aerovo run` does and prints
// what it found, to check a flight's files.
#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>

#include "aerovo/cli/command.h"
#include "aerovo/core/error.h"
#include "aerovo/frames/frame_source.h"
#include "aerovo/frames/image_metadata.h"
#include "aerovo/frames/video_text_track.h"
#include "aerovo/telemetry/telemetry_readers.h"

namespace aerovo::cli {
namespace {

// "make model" without blanks around either ("unknown" parts left out).
std::string TrimmedJoin(const std::string& make, const std::string& model) {
  const auto trim = [](const std::string& v) {
    const std::size_t b = v.find_first_not_of(" \t");
    return b == std::string::npos ? std::string() : v.substr(b, v.find_last_not_of(" \t") - b + 1);
  };
  const std::string a = trim(make), b = trim(model);
  return a.empty() ? b : b.empty() ? a : a + " " + b;
}

struct TelemetryArgs {
  std::string path;
  bool lenient = false;
  bool print_samples = false;
};

std::string Opt(const std::optional<double>& v, int decimals = 3) {
  return v ? fmt::format("{:.{}f}", *v, decimals) : std::string();
}

TelemetryReadResult ReadAny(const TelemetryArgs& args) {
  TelemetryReadOptions options;
  options.lenient = args.lenient;
  const std::filesystem::path path(args.path);
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    ImageFolderSource folder(path);  // same order as `aerovo run` uses
    for (const std::string& w : folder.warnings()) fmt::print(stderr, "warning: {}\n", w);
    return TelemetryFromImages(folder.metadata(), options);
  }
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  if (ext == ".jpg" || ext == ".jpeg" || ext == ".tif" || ext == ".tiff" || ext == ".png" ||
      ext == ".dng") {
    const ImageMetadata m = ReadImageMetadata(path);
    // Each value is printed with its unit, or "unknown" when the photo does not have it.
    const auto mm = [](const std::optional<double>& v, int decimals) {
      return v ? fmt::format("{:.{}f} mm", *v, decimals) : std::string("unknown");
    };
    fmt::print("photo        {}x{} px, {}{}, focal {} (35 mm equivalent {})\n", m.width_px,
               m.height_px,
               m.make.empty() && m.model.empty() ? std::string("unknown camera")
                                                 : TrimmedJoin(m.make, m.model),
               m.serial_number.empty() ? "" : fmt::format(" (serial {})", m.serial_number),
               mm(m.focal_length_mm, 2), mm(m.focal_length_35mm_mm, 1));
    // Where the XMP values came from (docs/inputs.md, "XMP in EXIF 0x02bc"), whose namespace
    // they were read from ("XMP of other vendors"), and each of them or "unknown".
    const bool has_xmp = m.rel_alt_m || m.abs_alt_m || m.gimbal_yaw_deg || m.gimbal_pitch_deg ||
                         m.gimbal_roll_deg || m.flight_yaw_deg || m.flight_pitch_deg ||
                         m.flight_roll_deg || m.calibrated_focal_px;
    using Src = ImageMetadata::XmpSource;
    const std::string vendor = m.xmp_vendor == ImageMetadata::XmpVendor::kNone
                                   ? std::string()
                                   : fmt::format(" ({} values)", XmpVendorName(m.xmp_vendor));
    fmt::print("xmp          {}{}\n",
               m.xmp_source == Src::kIfd0XmlPacket
                   ? "read from the EXIF tag 0x02bc of IFD0 (XMLPacket)"
               : m.xmp_source == Src::kExifIfdApplicationNotes
                   ? "read from the EXIF tag 0x02bc of the Exif sub-IFD (ApplicationNotes)"
               : has_xmp ? "read from the photo's XMP segment"
                         : "none (the photo has no DJI, Parrot, Pix4D Camera or senseFly XMP "
                           "values)",
               vendor);
    if (has_xmp) {
      const auto val = [](const std::optional<double>& v, const char* unit) {
        return v ? fmt::format("{:.1f} {}", *v, unit) : std::string("unknown");
      };
      fmt::print(
          "xmp values   relative altitude {}, absolute altitude {}, gimbal yaw {}, pitch {}, "
          "roll {}, flight yaw {}, pitch {}, roll {}\n",
          val(m.rel_alt_m, "m"), val(m.abs_alt_m, "m"), val(m.gimbal_yaw_deg, "deg"),
          val(m.gimbal_pitch_deg, "deg"), val(m.gimbal_roll_deg, "deg"),
          val(m.flight_yaw_deg, "deg"), val(m.flight_pitch_deg, "deg"),
          val(m.flight_roll_deg, "deg"));
    }
    // A payload's camera (docs/inputs.md, "Payloads of several cameras").
    if (!m.band_name.empty() || !m.image_source.empty() || !m.capture_id.empty()) {
      fmt::print("payload      {}{}{}\n",
                 !m.band_name.empty()      ? fmt::format("band {}", m.band_name)
                 : !m.image_source.empty() ? fmt::format("camera {}", m.image_source)
                                           : std::string("no band or camera named"),
                 m.rig_camera_index ? fmt::format(" (rig camera {})", *m.rig_camera_index) : "",
                 m.capture_id.empty() ? "" : fmt::format(", capture {}", m.capture_id));
    }
    if (m.focal_plane_px_per_mm) {
      fmt::print("focal plane  {:.2f} px/mm (EXIF FocalPlaneXResolution)\n",
                 *m.focal_plane_px_per_mm);
    }
    return TelemetryFromImages({m}, options);
  }
  return ReadTelemetryInput(path, options);  // a video: the captions in its subtitle track
}

void Run(const TelemetryArgs& args) {
  const TelemetryReadResult r = ReadAny(args);
  const Telemetry& t = r.telemetry;
  double lat0 = 90, lat1 = -90, lon0 = 180, lon1 = -180;
  int frames = 0, rel = 0, abs = 0, yaw = 0, fixes = 0;
  for (const TelemetrySample& s : t.samples()) {
    if (s.has_fix) {  // records without a fix keep heights and angles, not a position
      ++fixes;
      lat0 = std::min(lat0, s.lat_deg);
      lat1 = std::max(lat1, s.lat_deg);
      lon0 = std::min(lon0, s.lon_deg);
      lon1 = std::max(lon1, s.lon_deg);
    }
    frames += s.frame_index.has_value();
    rel += s.rel_alt_m.has_value();
    abs += s.abs_alt_m.has_value();
    yaw += s.CameraYawDeg().has_value();
  }
  fmt::print("source       {}\n", args.path);
  fmt::print("records      {} accepted, {} malformed skipped, {} without GPS fix\n", r.records,
             r.skipped_records, r.no_fix_records);
  fmt::print("time         {:.3f} .. {:.3f} s\n", t.start_time_s(), t.end_time_s());
  if (fixes > 0) {
    fmt::print("latitude     {:.7f} .. {:.7f} deg\n", lat0, lat1);
    fmt::print("longitude    {:.7f} .. {:.7f} deg\n", lon0, lon1);
  } else {
    fmt::print("latitude     none: no record has a GPS fix\n");
    fmt::print("longitude    none\n");
  }
  fmt::print("with         frame index {}, relative altitude {}, absolute altitude {}, yaw {}\n",
             frames, rel, abs, yaw);
  if (!r.camera_triggers.empty()) {
    // The clock of the samples above; `aerovo run` pairs a photo folder with them one by one.
    fmt::print("camera       {} photo(s) logged by the autopilot, {:.3f} .. {:.3f} s\n",
               r.camera_triggers.size(), r.camera_triggers.front().time_s,
               r.camera_triggers.back().time_s);
  }
  for (const std::string& w : r.warnings) fmt::print(stderr, "warning: {}\n", w);
  if (args.print_samples) {
    fmt::print(
        "time_s,frame,lat_deg,lon_deg,abs_alt_m,rel_alt_m,yaw_deg,gimbal_yaw_deg,"
        "gimbal_pitch_deg,focal_35mm_mm\n");
    for (const TelemetrySample& s : t.samples()) {
      const auto deg = [&](double v) { return s.has_fix ? fmt::format("{:.8f}", v) : ""; };
      fmt::print("{:.3f},{},{},{},{},{},{},{},{},{}\n", s.time_s,
                 s.frame_index ? std::to_string(*s.frame_index) : std::string(), deg(s.lat_deg),
                 deg(s.lon_deg), Opt(s.abs_alt_m), Opt(s.rel_alt_m), Opt(s.yaw_deg, 2),
                 Opt(s.gimbal_yaw_deg, 2), Opt(s.gimbal_pitch_deg, 2),
                 Opt(s.focal_length_35mm_mm, 1));
    }
  }
}

void RegisterTelemetryCommand(CLI::App& app) {
  auto args = std::make_shared<TelemetryArgs>();
  CLI::App* cmd =
      app.add_subcommand("telemetry",
                         "Read a telemetry source (DJI .srt, .gpx, .csv, ArduPilot .bin/.log, PX4 "
                         ".ulg, MAVLink .tlog, the DJI captions in a video's subtitle track, "
                         "a photo or a photo folder) and summarise "
                         "it;\nmalformed records are errors naming file:line unless --lenient");
  cmd->add_option("source", args->path, "Telemetry file, video, photo, or folder of photos")
      ->required();
  cmd->add_flag("--lenient", args->lenient,
                "Skip malformed records (counted and listed) instead of stopping at the first");
  cmd->add_flag("--print", args->print_samples, "Print every accepted sample as CSV");
  cmd->callback([args] { Run(*args); });
}

AEROVO_REGISTER_COMMAND(RegisterTelemetryCommand);

}  // namespace
}  // namespace aerovo::cli
