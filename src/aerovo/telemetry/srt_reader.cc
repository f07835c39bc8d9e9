// DJI .SRT subtitle telemetry. Formats seen in DJI files (see telemetry_readers.h); the
// parser is hand-written (no std::regex: its recursion can overflow on hostile input).
#include <cctype>
#include <istream>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "aerovo/telemetry/parse_util.h"
#include "aerovo/telemetry/telemetry_readers.h"

namespace aerovo {
namespace {

using io_detail::ParseDouble;
using io_detail::ParseInt;
using io_detail::RecordErrors;
using io_detail::Trim;

struct Line {
  long number;
  std::string text;
};

// Removes HTML-like tags (<font size="28">, </font>) that DJI wraps around the text.
std::string StripTags(std::string_view s) {
  std::string r;
  r.reserve(s.size());
  bool in_tag = false;
  for (char c : s) {
    if (c == '<') {
      in_tag = true;
    } else if (c == '>' && in_tag) {
      in_tag = false;
    } else if (!in_tag) {
      r.push_back(c);
    }
  }
  return r;
}

bool IsKeyChar(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

// Fields of one subtitle block as read from its text.
struct BlockFields {
  std::optional<double> lat, lon, rel_alt, abs_alt, focal35, gb_yaw, gb_pitch, gb_roll;
  std::optional<long long> counter;
  std::optional<double> unix_time;
  std::string error;  // First problem met (value that does not parse).
  long line = 0;      // Number of the line being parsed (1-based).
  long counter_line = 0;
  std::map<const std::optional<double>*, long> line_of;  // Line that set each value.

  void Fail(std::string msg) {
    if (error.empty()) error = std::move(msg);
  }
  void SetNumber(std::optional<double>& field, std::string_view key, std::string_view value) {
    auto v = ParseDouble(value);
    if (!v) {
      Fail(fmt::format("{} value '{}' is not a number", key, value));
      return;
    }
    field = v;
    line_of[&field] = line;
  }
  void SetCounter(std::optional<long long> c) {
    if (!c) return;
    counter = c;
    counter_line = line;
  }
};

// "key : value key2: value2" inside one [...] group.
void ParseBracket(std::string_view content, BlockFields& f) {
  std::size_t p = 0;
  while (p < content.size()) {
    while (p < content.size() && !IsKeyChar(content[p])) ++p;
    const std::size_t kb = p;
    while (p < content.size() && IsKeyChar(content[p])) ++p;
    const std::string key = io_detail::ToLower(content.substr(kb, p - kb));
    while (p < content.size() && content[p] == ' ') ++p;
    if (p >= content.size() || content[p] != ':') continue;  // Not a key: skip the word.
    ++p;
    while (p < content.size() && content[p] == ' ') ++p;
    const std::size_t vb = p;
    while (p < content.size() && content[p] != ' ') ++p;
    const std::string_view value = content.substr(vb, p - vb);
    if (key == "latitude") {
      f.SetNumber(f.lat, key, value);
    } else if (key == "longitude" || key == "longtitude") {
      f.SetNumber(f.lon, key, value);
    } else if (key == "rel_alt") {
      f.SetNumber(f.rel_alt, key, value);
    } else if (key == "abs_alt" || key == "altitude") {
      f.SetNumber(f.abs_alt, key, value);
    } else if (key == "focal_len") {
      f.SetNumber(f.focal35, key, value);
      // Older firmware (Mavic Pro, Mavic Air 2) writes an integer in tenths of a millimetre
      // (240 = 24 mm); newer firmware writes millimetres with decimals (24.00, tele 166.00).
      // So: an integer >= 100 is tenths; anything with a decimal point is millimetres.
      if (f.focal35 && value.find('.') == std::string_view::npos && *f.focal35 >= 100.0) {
        *f.focal35 /= 10.0;
      }
    } else if (key == "gb_yaw") {
      f.SetNumber(f.gb_yaw, key, value);
    } else if (key == "gb_pitch") {
      f.SetNumber(f.gb_pitch, key, value);
    } else if (key == "gb_roll") {
      f.SetNumber(f.gb_roll, key, value);
    }
  }
}

// Integer after "<key>" and an optional ':' (e.g. "FrameCnt: 12", "SrtCnt : 12").
std::optional<long long> CounterAfter(std::string_view line, std::string_view key) {
  const std::size_t k = line.find(key);
  if (k == std::string_view::npos) return std::nullopt;
  std::size_t p = k + key.size();
  while (p < line.size() && (line[p] == ' ' || line[p] == ':')) ++p;
  std::size_t e = p;
  while (e < line.size() && std::isdigit(static_cast<unsigned char>(line[e]))) ++e;
  return ParseInt(line.substr(p, e - p));
}

// Values inside "NAME(a,b,c)" or "NAME (a, b, c)" starting at or after `from`.
std::optional<std::vector<std::string_view>> ParenValues(std::string_view line,
                                                         std::size_t name_end) {
  std::size_t p = name_end;
  while (p < line.size() && line[p] == ' ') ++p;
  if (p >= line.size() || line[p] != '(') return std::nullopt;
  const std::size_t close = line.find(')', p);
  if (close == std::string_view::npos) return std::nullopt;
  std::vector<std::string_view> values;
  std::string_view inner = line.substr(p + 1, close - p - 1);
  std::size_t b = 0;
  while (true) {
    const std::size_t c = inner.find(',', b);
    values.push_back(Trim(inner.substr(b, c == std::string_view::npos ? inner.npos : c - b)));
    if (c == std::string_view::npos) break;
    b = c + 1;
  }
  return values;
}

void ParseTextLine(std::string_view line, BlockFields& f) {
  f.SetCounter(CounterAfter(line, "FrameCnt"));
  f.SetCounter(CounterAfter(line, "SrtCnt"));
  // Bracketed fields.
  for (std::size_t p = line.find('['); p != std::string_view::npos; p = line.find('[', p)) {
    const std::size_t close = line.find(']', p);
    if (close == std::string_view::npos) {
      f.Fail("unclosed '[' in telemetry line");
      break;
    }
    ParseBracket(line.substr(p + 1, close - p - 1), f);
    p = close;
  }
  // Older formats.
  if (const std::size_t g = line.find("GPS"); g != std::string_view::npos) {
    if (auto v = ParenValues(line, g + 3)) {
      if (v->size() < 2) {
        f.Fail("GPS(...) needs longitude and latitude");
      } else {
        f.SetNumber(f.lon, "GPS longitude", (*v)[0]);
        f.SetNumber(f.lat, "GPS latitude", (*v)[1]);
      }
    }
  }
  if (const std::size_t b = line.find("BAROMETER"); b != std::string_view::npos) {
    std::size_t p = b + 9;
    while (p < line.size() && (line[p] == ' ' || line[p] == ':')) ++p;
    std::size_t e = p;
    while (e < line.size() && line[e] != ' ' && line[e] != ',') ++e;
    std::string_view v = line.substr(p, e - p);
    if (!v.empty() && (v.back() == 'm' || v.back() == 'M')) v.remove_suffix(1);
    f.SetNumber(f.rel_alt, "BAROMETER", v);
  }
  if (const std::size_t h = line.find("HOME"); h != std::string_view::npos) {
    const std::size_t close = line.find(')', h);
    if (close != std::string_view::npos) {
      if (auto t = io_detail::ParseDateTime(line.substr(close + 1))) f.unix_time = t;
    }
  }
  // Mavic 2: "..., D 24.38m, H 19.30m, H.S 0.00m/s, ..."
  for (std::size_t p = line.find("H "); p != std::string_view::npos; p = line.find("H ", p + 1)) {
    if (p > 0 && !(line[p - 1] == ' ' || line[p - 1] == ',')) continue;
    std::size_t e = p + 2;
    while (e < line.size() && line[e] != 'm' && line[e] != ',') ++e;
    if (e < line.size() && line[e] == 'm')
      f.SetNumber(f.rel_alt, "H", line.substr(p + 2, e - p - 2));
    break;
  }
  // A whole line that is a date ("2023-05-01 12:00:00,123,456").
  if (!line.empty() && std::isdigit(static_cast<unsigned char>(line.front()))) {
    if (auto t = io_detail::ParseDateTime(line)) f.unix_time = t;
  }
}

// The line holding the value ValidateSample refuses in `s` (built from `f`): each value of `f`
// alone in an otherwise valid sample, the one refused with the whole sample's message; else
// `fallback` (the sample is valid, or no single value explains it).
long LineOfRefusedValue(const TelemetrySample& s, const BlockFields& f, long fallback) {
  const auto refusal = [](const TelemetrySample& t) -> std::string {
    try {
      ValidateSample(t, "");
      return "";
    } catch (const InputError& e) {
      return e.what();
    }
  };
  const std::string whole = refusal(s);
  if (whole.empty()) return fallback;
  TelemetrySample valid;
  valid.time_s = s.time_s;
  const std::pair<const std::optional<double>*, void (*)(TelemetrySample&, double)> fields[] = {
      {&f.lat, [](TelemetrySample& t, double v) { t.lat_deg = v; }},
      {&f.lon, [](TelemetrySample& t, double v) { t.lon_deg = v; }},
      {&f.abs_alt, [](TelemetrySample& t, double v) { t.abs_alt_m = v; }},
      {&f.rel_alt, [](TelemetrySample& t, double v) { t.rel_alt_m = v; }},
      {&f.gb_yaw, [](TelemetrySample& t, double v) { t.gimbal_yaw_deg = v; }},
      {&f.gb_pitch, [](TelemetrySample& t, double v) { t.gimbal_pitch_deg = v; }},
      {&f.gb_roll, [](TelemetrySample& t, double v) { t.gimbal_roll_deg = v; }},
      {&f.focal35, [](TelemetrySample& t, double v) { t.focal_length_35mm_mm = v; }},
  };
  for (const auto& [value, set] : fields) {
    const auto at = f.line_of.find(value);
    if (!*value || at == f.line_of.end()) continue;
    TelemetrySample alone = valid;
    set(alone, **value);
    if (refusal(alone) == whole) return at->second;
  }
  return fallback;
}

// The lines of the file, numbered from 1, without "\r" line ends and the UTF-8 byte-order mark.
std::vector<Line> ReadLines(std::istream& in) {
  std::vector<Line> lines;
  std::string s;
  long n = 0;
  while (std::getline(in, s)) {
    ++n;
    if (!s.empty() && s.back() == '\r') s.pop_back();
    if (n == 1 && s.rfind("\xEF\xBB\xBF", 0) == 0) s.erase(0, 3);  // UTF-8 BOM
    lines.push_back({n, std::move(s)});
  }
  return lines;
}

// The sample of subtitle `number` (block at `block_line`, start time `start_s`) from its text's
// fields: nullopt when the fields are malformed (reported through `errors` at error_line or
// block_line), say no GPS fix (counted in no_fix) or fail AcceptSample.
std::optional<TelemetrySample> SampleOfBlock(const BlockFields& f, long long number, double start_s,
                                             long block_line, long error_line, RecordErrors& errors,
                                             int& no_fix) {
  if (!f.error.empty()) {
    errors.Report(error_line, f.error);
    return std::nullopt;
  }
  if (!f.lat || !f.lon) {
    errors.Report(block_line, fmt::format("subtitle {} has no {}", number,
                                          !f.lat && !f.lon ? "latitude and longitude"
                                          : !f.lat         ? "latitude"
                                                           : "longitude"));
    return std::nullopt;
  }
  if (*f.lat == 0.0 && *f.lon == 0.0) {
    ++no_fix;
    return std::nullopt;
  }
  TelemetrySample s;
  s.time_s = start_s;
  s.unix_time_s = f.unix_time;
  if (f.counter) {
    if (*f.counter < 1 || *f.counter > 100000000) {
      errors.Report(f.counter_line, fmt::format("frame counter {} out of range", *f.counter));
      return std::nullopt;
    }
    s.frame_index = static_cast<int>(*f.counter - 1);
  }
  s.lat_deg = *f.lat;
  s.lon_deg = *f.lon;
  s.rel_alt_m = f.rel_alt;
  s.abs_alt_m = f.abs_alt;
  s.focal_length_35mm_mm = f.focal35;
  s.gimbal_yaw_deg = f.gb_yaw;
  s.gimbal_pitch_deg = f.gb_pitch;
  s.gimbal_roll_deg = f.gb_roll;
  // A value out of range is named at its own line, not the subtitle's first.
  if (!io_detail::AcceptSample(s, LineOfRefusedValue(s, f, block_line), errors)) {
    return std::nullopt;
  }
  return s;
}

}  // namespace

TelemetryReadResult ParseDjiSrt(std::istream& in, const std::string& source_name,
                                const TelemetryReadOptions& options) {
  Validate(options);
  RecordErrors errors(options, source_name);
  const std::vector<Line> lines = ReadLines(in);
  std::vector<TelemetrySample> samples;
  int no_fix = 0;
  std::optional<double> last_time;
  std::size_t i = 0;
  const auto blank = [&](std::size_t k) { return Trim(lines[k].text).empty(); };
  const auto skip_block = [&] {
    while (i < lines.size() && !blank(i)) ++i;
  };
  while (i < lines.size()) {
    if (blank(i)) {
      ++i;
      continue;
    }
    const long block_line = lines[i].number;
    const auto number = ParseInt(lines[i].text);
    if (!number) {
      errors.Report(block_line, fmt::format("expected a subtitle number, found '{}'",
                                            Trim(lines[i].text).substr(0, 60)));
      skip_block();
      continue;
    }
    ++i;
    if (i >= lines.size() || blank(i)) {
      errors.Report(block_line, fmt::format("subtitle {} has no timing line", *number));
      skip_block();
      continue;
    }
    const std::string& timing = lines[i].text;
    const std::size_t arrow = timing.find("-->");
    const std::optional<double> start =
        arrow == std::string::npos
            ? std::nullopt
            : io_detail::ParseSrtClock(std::string_view(timing).substr(0, arrow));
    if (!start) {
      errors.Report(lines[i].number,
                    fmt::format("bad timing line '{}' (expected HH:MM:SS,mmm --> HH:MM:SS,mmm)",
                                Trim(timing).substr(0, 60)));
      skip_block();
      continue;
    }
    const long timing_line = lines[i].number;
    ++i;
    BlockFields f;
    long error_line = timing_line;
    for (; i < lines.size() && !blank(i); ++i) {
      // A subtitle number followed by a timing line starts the next block even when the
      // blank separator line is missing (seen in hand-edited and concatenated files).
      if (i + 1 < lines.size() && ParseInt(lines[i].text) &&
          lines[i + 1].text.find("-->") != std::string::npos) {
        break;
      }
      const bool had_error = !f.error.empty();
      f.line = lines[i].number;
      ParseTextLine(StripTags(lines[i].text), f);
      if (!had_error && !f.error.empty()) error_line = lines[i].number;
    }
    std::optional<TelemetrySample> sample =
        SampleOfBlock(f, *number, *start, block_line, error_line, errors, no_fix);
    if (!sample) continue;
    TelemetrySample& s = *sample;
    if (last_time && s.time_s < *last_time) {
      errors.Report(timing_line,
                    fmt::format("time {:.3f} s is earlier than the previous subtitle's {:.3f} s "
                                "(timestamps out of order)",
                                s.time_s, *last_time));
      continue;
    }
    last_time = s.time_s;
    samples.push_back(std::move(s));
  }
  return io_detail::Finish(std::move(samples), errors, no_fix, "SRT file");
}

TelemetryReadResult ReadDjiSrt(const std::filesystem::path& path,
                               const TelemetryReadOptions& options) {
  std::ifstream in = io_detail::OpenInput(path);
  return ParseDjiSrt(in, path.string(), options);
}

}  // namespace aerovo
