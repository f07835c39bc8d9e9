// DJI .SRT subtitle telemetry. Formats seen in DJI files (see telemetry_readers.h); the
// parser is hand-written (no std::regex: its recursion can overflow on hostile input).
#include <cctype>
#include <cmath>
#include <functional>
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

using io_detail::ParseInt;
using io_detail::RecordErrors;

struct Line {
  long number;
  std::string text;
};

// The order of the values of a positional "GPS(a, b, c)" / "RTK (a, b, c)" record.
enum class GpsOrder { kUnknown, kLonLat, kLatLon };

// "N/A" (DJI's "no value" before the GPS fix).
bool IsNotAvailable(std::string_view v) {
  v = TrimSpace(v);
  return v == "N/A" || v == "n/a" || v == "NA";
}

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
  std::optional<double> yaw, pitch, roll;  // aircraft attitude (drone_*, Drone: Yaw, F.PRY)
  std::optional<double> hb, hs;            // "Hb:" / "Hs:" heights, used without BAROMETER/H
  bool no_fix = false;                     // a latitude or longitude written "N/A"
  int bracket_fields = 0;                  // "[key : value]" fields read, known or not
  GpsOrder order = GpsOrder::kUnknown;     // the file's GPS(...) order (FileGpsOrder)
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
    auto v = ParseDecimal(value);
    if (!v) {
      Fail(fmt::format("{} value '{}' is not a number", Printable(key), Printable(value)));
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

// "key : value key2: value2" inside one [...] group. A key whose value is another key names a
// group (Mavic 2 Enterprise: "[Drone: Yaw:-146.0, Pitch:-0.6, Roll:1.3]"); values end at a
// blank or a ','.
void ParseBracket(std::string_view content, BlockFields& f) {
  std::size_t p = 0;
  std::string group;
  while (p < content.size()) {
    while (p < content.size() && !IsKeyChar(content[p])) ++p;
    const std::size_t kb = p;
    while (p < content.size() && IsKeyChar(content[p])) ++p;
    std::string key = io_detail::ToLower(content.substr(kb, p - kb));
    while (p < content.size() && content[p] == ' ') ++p;
    if (p >= content.size() || content[p] != ':') continue;  // Not a key: skip the word.
    ++p;
    while (p < content.size() && content[p] == ' ') ++p;
    std::size_t q = p;
    while (q < content.size() && IsKeyChar(content[q])) ++q;
    if (q > p && q < content.size() && content[q] == ':' &&
        !std::isdigit(static_cast<unsigned char>(content[p]))) {
      group = key;  // "Drone:" followed by "Yaw:..."
      continue;
    }
    if (!group.empty()) key = group + "_" + key;
    ++f.bracket_fields;
    const std::size_t vb = p;
    while (p < content.size() && content[p] != ' ' && content[p] != ',') ++p;
    const std::string_view value = content.substr(vb, p - vb);
    if ((key == "latitude" || key == "longitude" || key == "longtitude") && IsNotAvailable(value)) {
      f.no_fix = true;
    } else if (key == "latitude") {
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
    } else if (key == "drone_yaw") {
      f.SetNumber(f.yaw, key, value);
    } else if (key == "drone_pitch") {
      f.SetNumber(f.pitch, key, value);
    } else if (key == "drone_roll") {
      f.SetNumber(f.roll, key, value);
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
    values.push_back(TrimSpace(inner.substr(b, c == std::string_view::npos ? inner.npos : c - b)));
    if (c == std::string_view::npos) break;
    b = c + 1;
  }
  return values;
}

// Position of the word `name` in `line` (not inside a longer word), from `from`; npos if none.
std::size_t FindWord(std::string_view line, std::string_view name, std::size_t from = 0) {
  for (std::size_t p = line.find(name, from); p != std::string_view::npos;
       p = line.find(name, p + 1)) {
    const bool starts = p == 0 || !IsKeyChar(line[p - 1]);
    const std::size_t e = p + name.size();
    const bool ends = e >= line.size() || !IsKeyChar(line[e]) || line[e] == '(';
    if (starts && ends) return p;
  }
  return std::string_view::npos;
}

// A value of a DJI record without its unit: "0.0M" -> "0.0", "85.80m" -> "85.80",
// "-24.4°" -> "-24.4" (the degree sign in UTF-8, C2 B0, or Latin-1, B0).
std::string_view WithoutUnit(std::string_view v) {
  v = TrimSpace(v);
  if (v.size() >= 2 && v.substr(v.size() - 2) == "\xC2\xB0") v.remove_suffix(2);
  if (!v.empty() && (v.back() == 'm' || v.back() == 'M' || v.back() == '\xB0')) v.remove_suffix(1);
  return TrimSpace(v);
}

// What the third value of "GPS(a, b, c)" says about the order of a and b: an altitude in metres
// ("0.0M": the enterprise M200/M300 records, GPS(latitude, longitude, altitude)) or a satellite
// count (an integer: Phantom 3/4, Mavic, P4 RTK, GPS(longitude, latitude, satellites)).
GpsOrder OrderOfThirdValue(std::string_view c) {
  c = TrimSpace(c);
  if (c.empty()) return GpsOrder::kUnknown;
  if (c.back() == 'M' || c.back() == 'm') {
    return ParseDecimal(c.substr(0, c.size() - 1)) ? GpsOrder::kLatLon : GpsOrder::kUnknown;
  }
  if (c.find_first_not_of("0123456789") == std::string_view::npos) return GpsOrder::kLonLat;
  return GpsOrder::kUnknown;
}

// The values of the position record of `line` ("GPS(...)", "GPS (...)" or "RTK (...)"), or
// nullopt when the line has none; `*name` is set to the record's name.
std::optional<std::vector<std::string_view>> PositionValues(std::string_view line,
                                                            std::string_view* name) {
  for (std::string_view n : {"GPS", "RTK"}) {
    const std::size_t g = FindWord(line, n);
    if (g == std::string_view::npos) continue;
    if (auto v = ParenValues(line, g + n.size())) {
      *name = n;
      return v;
    }
  }
  return std::nullopt;
}

// A number after "<key>" and optional blanks, ':' or '(' (BAROMETER:99.8, BAROMETER:0.3M,
// BAROMETER(91.2), Hb:12.3m), its unit removed; nullopt when the key is not on the line, and the
// raw text (which then does not parse) otherwise.
std::optional<std::string_view> ValueAfter(std::string_view line, std::string_view key) {
  const std::size_t b = FindWord(line, key);
  if (b == std::string_view::npos) return std::nullopt;
  std::size_t p = b + key.size();
  const std::size_t after_key = p;
  while (p < line.size() && (line[p] == ' ' || line[p] == ':' || line[p] == '(')) ++p;
  if (p == after_key) return std::nullopt;  // a word, not a key ("H.S", "Hbar")
  std::size_t e = p;
  while (e < line.size() && line[e] != ' ' && line[e] != ',' && line[e] != ')') ++e;
  return WithoutUnit(line.substr(p, e - p));
}

// The hemisphere letter of a position value "N: 40.7685" / "W: 109.3392" (Autel's records,
// GPS(W: lon, N: lat, altm); a blank may stand for the colon), or '\0' for a plain number.
char Hemisphere(std::string_view v) {
  v = TrimSpace(v);
  if (v.size() < 3 || (v[1] != ':' && v[1] != ' ')) return '\0';
  return v[0] == 'N' || v[0] == 'S' || v[0] == 'E' || v[0] == 'W' ? v[0] : '\0';
}

// A position whose values carry their hemisphere: one of N/S (latitude), one of E/W (longitude),
// in either order, S and W negative; the magnitudes are not signed.
void ReadHemispherePosition(std::string_view name, std::string_view a, std::string_view b,
                            BlockFields& f) {
  std::optional<double> lat, lon;
  for (std::string_view v : {a, b}) {
    const char h = Hemisphere(v);  // then v holds at least 3 characters
    const auto x = h != '\0' ? ParseDecimal(TrimSpace(v).substr(2)) : std::nullopt;
    if (h == '\0' || !x || *x < 0.0) {
      f.Fail(
          fmt::format("{} value '{}' is not a hemisphere letter (N, S, E, W) and a number of "
                      "degrees",
                      name, Printable(v)));
      return;
    }
    std::optional<double>& slot = h == 'N' || h == 'S' ? lat : lon;
    if (slot) {
      f.Fail(fmt::format("{}({}, {}) gives two {}", name, Printable(a), Printable(b),
                         &slot == &lat ? "latitudes" : "longitudes"));
      return;
    }
    slot = h == 'S' || h == 'W' ? -*x : *x;
  }
  if (*lat == 0.0 && *lon == 0.0) {
    f.no_fix = true;
    return;
  }
  f.lat = lat;
  f.lon = lon;
  f.line_of[&f.lat] = f.line_of[&f.lon] = f.line;
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
  // Positional records: the order of latitude and longitude is the file's (FileGpsOrder), or
  // each value's own hemisphere letter.
  std::string_view name;
  if (auto v = PositionValues(line, &name)) {
    if (v->size() < 2) {
      f.Fail(fmt::format("{}(...) needs latitude and longitude", name));
    } else if (Hemisphere((*v)[0]) != '\0' || Hemisphere((*v)[1]) != '\0') {
      ReadHemispherePosition(name, (*v)[0], (*v)[1], f);
    } else if (IsNotAvailable((*v)[0]) || IsNotAvailable((*v)[1])) {
      f.no_fix = true;  // "GPS(N/A,N/A,5)": no fix yet
    } else {
      const auto a = ParseDecimal((*v)[0]), b = ParseDecimal((*v)[1]);
      if (!a || !b) {
        f.Fail(
            fmt::format("{} value '{}' is not a number", name, Printable(!a ? (*v)[0] : (*v)[1])));
      } else if (*a == 0.0 && *b == 0.0) {
        f.no_fix = true;  // "GPS(0.0, 0.0, 0)": no fix yet, in either order
      } else if (f.order != GpsOrder::kUnknown) {
        const bool lat_first = f.order == GpsOrder::kLatLon;
        f.lat = lat_first ? a : b;
        f.lon = lat_first ? b : a;
        f.line_of[&f.lat] = f.line_of[&f.lon] = f.line;
      }
    }
  }
  // Heights; "N/A" leaves one unknown.
  const struct {
    const char* key;
    std::optional<double> BlockFields::*field;
  } heights[] = {
      {"BAROMETER", &BlockFields::rel_alt}, {"Hb", &BlockFields::hb}, {"Hs", &BlockFields::hs}};
  for (const auto& h : heights) {
    const auto v = ValueAfter(line, h.key);
    if (v && !IsNotAvailable(*v)) f.SetNumber(f.*h.field, h.key, *v);
  }
  if (const std::size_t h = FindWord(line, "HOME"); h != std::string_view::npos) {
    const std::size_t close = line.find(')', h);
    if (close != std::string_view::npos) {
      if (auto t = io_detail::ParseDateTime(line.substr(close + 1))) f.unix_time = t;
    }
  }
  // Mavic 2 / Mini / P4 RTK: "..., D 24.38m, H 19.30m, H.S 0.00m/s, ..."
  for (std::size_t p = line.find("H "); p != std::string_view::npos; p = line.find("H ", p + 1)) {
    if (p > 0 && !(line[p - 1] == ' ' || line[p - 1] == ',')) continue;
    std::size_t e = p + 2;
    while (e < line.size() && line[e] != 'm' && line[e] != ',') ++e;
    if (e < line.size() && line[e] == 'm')
      f.SetNumber(f.rel_alt, "H", line.substr(p + 2, e - p - 2));
    break;
  }
  // P4 RTK / Phantom 4 Pro: "F.PRY (2.7°, -7.0°, 110.1°), G.PRY (-24.4°, 0.0°, 110.4°)": pitch,
  // roll and yaw of the aircraft (F) and of the gimbal (G), degrees.
  const struct {
    const char* name;
    std::optional<double> BlockFields::*pitch, BlockFields::*roll, BlockFields::*yaw;
  } attitudes[] = {{"F.PRY", &BlockFields::pitch, &BlockFields::roll, &BlockFields::yaw},
                   {"G.PRY", &BlockFields::gb_pitch, &BlockFields::gb_roll, &BlockFields::gb_yaw}};
  for (const auto& a : attitudes) {
    const std::size_t k = line.find(a.name);
    if (k == std::string_view::npos) continue;
    const auto v = ParenValues(line, k + 5);
    if (!v || v->size() != 3) {
      f.Fail(fmt::format("{} needs (pitch, roll, yaw)", a.name));
      continue;
    }
    f.SetNumber(f.*a.pitch, fmt::format("{} pitch", a.name), WithoutUnit((*v)[0]));
    f.SetNumber(f.*a.roll, fmt::format("{} roll", a.name), WithoutUnit((*v)[1]));
    f.SetNumber(f.*a.yaw, fmt::format("{} yaw", a.name), WithoutUnit((*v)[2]));
  }
  // A whole line that is a date ("2023-05-01 12:00:00,123,456").
  if (!line.empty() && std::isdigit(static_cast<unsigned char>(line.front()))) {
    if (auto t = io_detail::ParseDateTime(line)) f.unix_time = t;
  }
}

// The order of the positional GPS/RTK records of the file, from their own markers (the third
// value, OrderOfThirdValue) or, without a marker, from a value that can only be a longitude
// (beyond +-90). kUnknown when the file has no positional record with a position. Throws
// InputError naming file:line when two records say different orders, or when no record decides
// (then naming the first one and both readings): the order is never guessed.
GpsOrder FileGpsOrder(const std::vector<Line>& lines, const std::string& source) {
  GpsOrder order = GpsOrder::kUnknown;
  long decided_line = 0;
  long undecided_line = 0;
  std::string undecided;
  std::string_view name;
  for (const Line& l : lines) {
    if (l.text.find('(') == std::string::npos) continue;
    const std::string text = StripTags(l.text);
    const auto v = PositionValues(text, &name);
    if (!v || v->size() < 2 || IsNotAvailable((*v)[0]) || IsNotAvailable((*v)[1])) continue;
    const auto a = ParseDecimal((*v)[0]), b = ParseDecimal((*v)[1]);
    if (!a || !b || (*a == 0.0 && *b == 0.0)) continue;  // bad numbers are reported later
    GpsOrder here = v->size() >= 3 ? OrderOfThirdValue((*v)[2]) : GpsOrder::kUnknown;
    if (here == GpsOrder::kUnknown) {
      if (std::abs(*a) > 90.0 && std::abs(*b) <= 90.0) here = GpsOrder::kLonLat;
      if (std::abs(*b) > 90.0 && std::abs(*a) <= 90.0) here = GpsOrder::kLatLon;
    }
    if (here == GpsOrder::kUnknown) {
      if (undecided_line == 0) {
        undecided_line = l.number;
        undecided = fmt::format(
            "{}({}, {}{}) does not say which value is the latitude (the third value is neither "
            "a satellite count nor an altitude in M): as (latitude, longitude) it is {}, {}; as "
            "(longitude, latitude) it is {}, {}",
            name, Printable((*v)[0]), Printable((*v)[1]),
            v->size() >= 3 ? ", " + Printable((*v)[2]) : "", *a, *b, *b, *a);
      }
      continue;
    }
    if (order == GpsOrder::kUnknown) {
      order = here;
      decided_line = l.number;
    } else if (here != order) {
      const auto say = [](GpsOrder o) {
        return o == GpsOrder::kLatLon ? "(latitude, longitude, altitude)"
                                      : "(longitude, latitude, satellites)";
      };
      throw InputError(fmt::format(
          "{}:{}: {} records in two orders: line {} reads as {}, this line as {}; which one is "
          "right cannot be decided",
          source, l.number, name, decided_line, say(order), say(here)));
    }
  }
  if (order == GpsOrder::kUnknown && undecided_line != 0) {
    throw InputError(fmt::format("{}:{}: {}", source, undecided_line, undecided));
  }
  return order;
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
      {&f.hb, [](TelemetrySample& t, double v) { t.rel_alt_m = v; }},
      {&f.hs, [](TelemetrySample& t, double v) { t.rel_alt_m = v; }},
      {&f.yaw, [](TelemetrySample& t, double v) { t.yaw_deg = v; }},
      {&f.pitch, [](TelemetrySample& t, double v) { t.pitch_deg = v; }},
      {&f.roll, [](TelemetrySample& t, double v) { t.roll_deg = v; }},
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

// The lines of the file, numbered from 1, read through TextLines (UTF-8 or UTF-16 with a
// byte-order mark, the mark removed; any line end; a NUL byte or an over-long line is an error).
std::vector<Line> ReadLines(std::istream& in, const std::string& source) {
  std::vector<Line> lines;
  io_detail::TextLines text(in, source);
  std::string s;
  while (text.Next(s)) lines.push_back({text.line(), std::move(s)});
  return lines;
}

// What a subtitle's problem is: a part missing (no position, no timing line: what a subtitle cut
// short lacks), text that does not parse (unclosed '[', a number cut inside: a cut when it is on
// the file's last line), or a wrong value (never a cut).
enum class Problem { kMissingPart, kBadText, kBadValue };
// report(line, message, kind).
using ReportProblem = std::function<void(long, const std::string&, Problem)>;

// The sample of subtitle `number` (block at `block_line`, start time `start_s`) from its text's
// fields: nullopt when the fields are malformed (reported through `report` at error_line or
// block_line) or fail AcceptSample. A record without a fix ("N/A", or 0, 0) is a sample with
// has_fix = false that keeps its heights and angles; so is, in a file none of whose subtitles
// has a position (`file_has_positions` false), a subtitle that holds the camera's fields (a frame
// counter, a date, "[key : value]" fields): the Mavic Air's SRT of early 2018 in dji_srt_parser's
// samples/mavic_air.SRT (FrameCnt, date, iso, shutter; no latitude or longitude anywhere).
std::optional<TelemetrySample> SampleOfBlock(const BlockFields& f, long long number, double start_s,
                                             long block_line, long error_line,
                                             bool file_has_positions, const ReportProblem& report,
                                             RecordErrors& errors) {
  if (!f.error.empty()) {
    report(error_line, f.error, Problem::kBadText);
    return std::nullopt;
  }
  const bool camera_fields = f.counter || f.unix_time || f.bracket_fields > 0;
  // No fix: "N/A", or latitude = longitude = 0 (DJI's values before the fix), or no position
  // among the camera's fields.
  const bool no_fix_record = f.no_fix || (f.lat && f.lon && *f.lat == 0.0 && *f.lon == 0.0) ||
                             (!f.lat && !f.lon && camera_fields && !file_has_positions);
  if (!no_fix_record && (!f.lat || !f.lon)) {
    report(block_line,
           fmt::format("subtitle {} has no {}", number,
                       !f.lat && !f.lon ? "latitude and longitude"
                       : !f.lat         ? "latitude"
                                        : "longitude"),
           Problem::kMissingPart);
    return std::nullopt;
  }
  TelemetrySample s;
  s.time_s = start_s;
  s.unix_time_s = f.unix_time;
  if (f.counter) {
    if (*f.counter < 1 || *f.counter > 100000000) {
      report(f.counter_line, fmt::format("frame counter {} out of range", *f.counter),
             Problem::kBadValue);
      return std::nullopt;
    }
    s.frame_index = static_cast<int>(*f.counter - 1);
  }
  s.has_fix = !no_fix_record;
  s.lat_deg = s.has_fix ? *f.lat : 0.0;
  s.lon_deg = s.has_fix ? *f.lon : 0.0;
  // Height above the take-off point: rel_alt, BAROMETER or H, else Hb, else Hs.
  s.rel_alt_m = f.rel_alt ? f.rel_alt : f.hb ? f.hb : f.hs;
  s.abs_alt_m = f.abs_alt;
  s.focal_length_35mm_mm = f.focal35;
  s.yaw_deg = f.yaw;
  s.pitch_deg = f.pitch;
  s.roll_deg = f.roll;
  s.gimbal_yaw_deg = f.gb_yaw;
  s.gimbal_pitch_deg = f.gb_pitch;
  s.gimbal_roll_deg = f.gb_roll;
  // A value out of range is named at its own line, not the subtitle's first.
  if (!io_detail::AcceptSample(s, LineOfRefusedValue(s, f, block_line), errors)) {
    return std::nullopt;
  }
  s.origin = errors.At(block_line);
  return s;
}

}  // namespace

TelemetryReadResult ParseDjiSrt(std::istream& in, const std::string& source_name,
                                const TelemetryReadOptions& options) {
  Validate(options);
  RecordErrors errors(options, source_name);
  const std::vector<Line> lines = ReadLines(in, source_name);
  const GpsOrder order = FileGpsOrder(lines, source_name);
  std::vector<TelemetrySample> samples;
  int no_fix = 0;
  std::optional<double> last_time;
  std::size_t i = 0;
  const auto blank = [&](std::size_t k) { return TrimSpace(lines[k].text).empty(); };
  const auto skip_block = [&] {
    while (i < lines.size() && !blank(i)) ++i;
  };
  // The last line with text: a subtitle that ends the file there while a part of it is missing
  // (no timing line, no position, a line cut inside a bracket or a number) is a recording that
  // stopped while writing it (dji_srt_parser's samples/broken_incomplete*.SRT): dropped with a
  // warning in both modes, as a cut last record of the other readers. Anything else, and any
  // problem before the last subtitle, goes through `errors` (strict: an error).
  std::size_t last_text = 0;
  for (std::size_t k = lines.size(); k-- > 0;) {
    if (!blank(k)) {
      last_text = k;
      break;
    }
  }
  // Whether any subtitle has a position (or says it has none yet: "N/A", 0, 0): a subtitle
  // without one is then malformed (or cut), not a record of a model that writes none.
  bool file_has_positions = false;
  for (const Line& l : lines) {
    BlockFields probe;
    probe.order = order;
    ParseTextLine(StripTags(l.text), probe);
    if (probe.lat || probe.lon || probe.no_fix) {
      file_has_positions = true;
      break;
    }
  }
  const auto problem = [&](long long number, bool cut, long line, const std::string& message) {
    if (cut) {
      if (static_cast<int>(errors.warnings().size()) < options.max_warnings) {
        errors.warnings().push_back(fmt::format(
            "{}: the last subtitle ({}) is cut short ({}): dropped (the recording stopped while "
            "writing it)",
            errors.At(line), number, message));
      }
      return;
    }
    errors.Report(line, message);
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
                                            Printable(TrimSpace(lines[i].text))));
      skip_block();
      continue;
    }
    const std::size_t number_at = i;
    ++i;
    if (i >= lines.size() || blank(i)) {
      problem(*number, number_at >= last_text, block_line,
              fmt::format("subtitle {} has no timing line", *number));
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
      problem(*number, i >= last_text, lines[i].number,
              fmt::format("bad timing line '{}' (expected HH:MM:SS,mmm --> HH:MM:SS,mmm)",
                          Printable(TrimSpace(timing))));
      skip_block();
      continue;
    }
    const long timing_line = lines[i].number;
    ++i;
    BlockFields f;
    f.order = order;
    long error_line = timing_line;
    const auto starts_block = [&](std::size_t k) {
      return k + 1 < lines.size() && ParseInt(lines[k].text) &&
             lines[k + 1].text.find("-->") != std::string::npos;
    };
    while (true) {
      for (; i < lines.size() && !blank(i); ++i) {
        // A subtitle number followed by a timing line starts the next block even when the
        // blank separator line is missing (seen in hand-edited and concatenated files).
        if (starts_block(i)) break;
        const bool had_error = !f.error.empty();
        f.line = lines[i].number;
        ParseTextLine(StripTags(lines[i].text), f);
        if (!had_error && !f.error.empty()) error_line = lines[i].number;
      }
      // The enterprise records (M30/M300 with H20-class cameras) go on after a blank line with a
      // line holding only "0", then "[dzoom_ratio: ...] [color_md : default]" and "</font>":
      // the rest of the same subtitle, not a new one.
      std::size_t k = i;
      while (k < lines.size() && blank(k)) ++k;
      if (k < lines.size() && TrimSpace(StripTags(lines[k].text)) == "0" && !starts_block(k)) {
        i = k + 1;
        continue;
      }
      break;
    }
    // The subtitle ends the file: a missing part, or a problem on the file's last line, is a cut.
    const bool reaches_end = i > last_text;
    const long last_line = lines[last_text].number;
    const ReportProblem report = [&](long line, const std::string& message, Problem kind) {
      const bool cut = reaches_end && (kind == Problem::kMissingPart ||
                                       (kind == Problem::kBadText && line == last_line));
      problem(*number, cut, line, message);
    };
    std::optional<TelemetrySample> sample = SampleOfBlock(
        f, *number, *start, block_line, error_line, file_has_positions, report, errors);
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
    if (!s.has_fix) ++no_fix;
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
