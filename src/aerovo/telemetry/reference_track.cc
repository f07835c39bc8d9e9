#include "aerovo/telemetry/reference_track.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "aerovo/core/error.h"
#include "aerovo/telemetry/csv_lines.h"
#include "aerovo/telemetry/parse_util.h"
#include "aerovo/telemetry/telemetry_readers.h"

namespace aerovo {
std::vector<ReferencePoint> ReadTumPoints(const std::filesystem::path& path,
                                          bool last_line_may_be_cut) {
  std::ifstream in(path);
  if (!in) throw InputError(fmt::format("cannot open TUM trajectory '{}'", path.string()));
  std::vector<ReferencePoint> points;
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    // getline stops at the end of the file on a line without its newline: a file still being
    // written, or of a run that was killed mid-line, may end in part of a pose.
    if (last_line_may_be_cut && in.eof()) break;
    const std::string_view trimmed = TrimSpace(line);
    if (trimmed.empty() || trimmed.front() == '#') continue;
    std::istringstream fields{std::string(trimmed)};
    double v[3] = {0.0, 0.0, 0.0};
    int n = 0;
    std::string token;
    while (fields >> token) {
      const std::optional<double> d = ParseDecimal(token);
      if (!d) {
        throw InputError(fmt::format("{}:{}: '{}' is not a number (TUM: t x y z qx qy qz qw)",
                                     path.string(), line_no, Printable(token)));
      }
      if (n < 3) v[n] = *d;
      ++n;
    }
    if (n < 3) {
      throw InputError(fmt::format("{}:{}: a TUM line needs at least t x y, got {} values",
                                   path.string(), line_no, n));
    }
    if (!points.empty() && v[0] < points.back().time_s) {
      throw InputError(fmt::format("{}:{}: time {} is before the previous line's {}", path.string(),
                                   line_no, v[0], points.back().time_s));
    }
    ReferencePoint p;
    p.time_s = v[0];
    p.x_m = v[1];
    p.y_m = v[2];
    points.push_back(p);
  }
  return points;
}

ReferenceTrack ReadReferenceTrack(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  ReferenceTrack track;
  if (ext == ".tum" || ext == ".txt") {
    track.format = "tum";
    track.points = ReadTumPoints(path);
  } else {
    const TelemetryReadResult t = ReadTelemetryFile(path);
    track.format = ext.empty() ? "telemetry" : ext.substr(1);
    track.geographic = true;
    for (const TelemetrySample& s : t.telemetry.samples()) {
      if (!s.has_fix) continue;  // a record without a position
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

ReferenceTrack ReadGroundTruthCsv(const std::filesystem::path& path) {
  std::ifstream in = io_detail::OpenInput(path);
  CsvLines csv(in, path.string());
  const auto fail = [&](long line, const std::string& what) {
    throw InputError(fmt::format("{}:{}: {}", path.string(), line, what));
  };
  static const char* const kColumns[] = {"frame", "time_s", "east_m", "north_m"};
  const std::vector<std::string>& header = csv.header();
  bool header_ok = header.size() >= 4;
  for (int c = 0; header_ok && c < 4; ++c) header_ok = TrimSpace(header[c]) == kColumns[c];
  if (!header_ok) {
    fail(csv.header_line(),
         "expected a header starting 'frame,time_s,east_m,north_m' (ground_truth.csv of aerovo "
         "simulate)");
  }
  ReferenceTrack track;
  track.path = path.string();
  track.format = "ground_truth_csv";
  std::vector<std::string> cells;
  while (csv.Next(cells)) {
    if (csv.unterminated_quote()) fail(csv.line(), "unterminated quote");
    if (cells.size() < 4) fail(csv.line(), "fewer than 4 columns");
    double v[4];
    for (int c = 0; c < 4; ++c) {
      const std::optional<double> d = ParseDecimal(cells[c]);
      if (!d) fail(csv.line(), fmt::format("{} '{}' is not a number", kColumns[c], cells[c]));
      v[c] = *d;
    }
    if (!io_detail::IsFrameNumber(v[0])) {
      fail(csv.line(), fmt::format("frame {} is not an integer >= 0", cells[0]));
    }
    if (!track.points.empty() && v[1] < track.points.back().time_s) {
      fail(csv.line(), fmt::format("time {} is before the previous row's {}", v[1],
                                   track.points.back().time_s));
    }
    ReferencePoint p;
    p.frame_index = static_cast<int>(v[0]);
    p.time_s = v[1];
    p.x_m = v[2];
    p.y_m = v[3];
    track.points.push_back(p);
  }
  if (track.points.empty()) fail(csv.line(), "no frames");
  return track;
}

}  // namespace aerovo
