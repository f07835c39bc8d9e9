#include "aerovo/io/reference_track.h"

#include <algorithm>
#include <cctype>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "aerovo/core/error.h"
#include "aerovo/io/parse_util.h"
#include "aerovo/io/telemetry_readers.h"

namespace aerovo {
namespace {

ReferenceTrack ReadTum(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(fmt::format("cannot open reference track '{}'", path.string()));
  ReferenceTrack track;
  track.format = "tum";
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const std::string_view trimmed = io_detail::Trim(line);
    if (trimmed.empty() || trimmed.front() == '#') continue;
    std::istringstream fields{std::string(trimmed)};
    std::vector<double> v;
    std::string token;
    while (fields >> token) {
      const std::optional<double> d = io_detail::ParseDouble(token);
      if (!d) {
        throw InputError(fmt::format("{}:{}: '{}' is not a number (TUM: t x y z qx qy qz qw)",
                                     path.string(), line_no, token));
      }
      v.push_back(*d);
    }
    if (v.size() < 3) {
      throw InputError(fmt::format("{}:{}: a TUM line needs at least t x y, got {} values",
                                   path.string(), line_no, v.size()));
    }
    if (!track.points.empty() && v[0] < track.points.back().time_s) {
      throw InputError(fmt::format("{}:{}: time {} is before the previous line's {}", path.string(),
                                   line_no, v[0], track.points.back().time_s));
    }
    ReferencePoint p;
    p.time_s = v[0];
    p.x_m = v[1];
    p.y_m = v[2];
    track.points.push_back(p);
  }
  return track;
}

}  // namespace

ReferenceTrack ReadReferenceTrack(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  ReferenceTrack track;
  if (ext == ".tum" || ext == ".txt") {
    track = ReadTum(path);
  } else {
    const TelemetryReadResult t = ReadTelemetryFile(path);
    track.format = ext.empty() ? "telemetry" : ext.substr(1);
    track.geographic = true;
    for (const TelemetrySample& s : t.telemetry.samples()) {
      ReferencePoint p;
      p.time_s = s.time_s;
      p.geo = GeoPoint{s.lat_deg, s.lon_deg, s.abs_alt_m.value_or(s.rel_alt_m.value_or(0.0))};
      p.frame_index = s.frame_index;
      track.points.push_back(p);
    }
  }
  track.path = path.string();
  if (track.points.size() < 2) {
    throw InputError(fmt::format("reference track '{}': needs at least 2 positions, found {}",
                                 path.string(), track.points.size()));
  }
  return track;
}

}  // namespace aerovo
