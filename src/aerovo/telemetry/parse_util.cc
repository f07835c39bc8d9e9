#include "aerovo/telemetry/parse_util.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <iterator>
#include <string>

#include <fmt/format.h>

namespace aerovo::io_detail {

std::string ToLower(std::string_view s) {
  std::string r(s);
  for (char& c : r) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return r;
}

std::optional<long long> ParseInt(std::string_view s) {
  s = TrimSpace(s);
  if (s.empty() || s.size() > 18) return std::nullopt;
  std::size_t i = 0;
  bool neg = false;
  if (s[0] == '+' || s[0] == '-') {
    neg = s[0] == '-';
    i = 1;
  }
  if (i == s.size()) return std::nullopt;
  long long v = 0;
  for (; i < s.size(); ++i) {
    if (!std::isdigit(static_cast<unsigned char>(s[i]))) return std::nullopt;
    v = v * 10 + (s[i] - '0');
  }
  return neg ? -v : v;
}

long long DaysFromCivil(int y, int m, int d) {
  y -= m <= 2;
  const long long era = (y >= 0 ? y : y - 399) / 400;
  const long long yoe = y - era * 400;
  const long long doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
  const long long doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return era * 146097 + doe - 719468;
}

namespace {

// Reads exactly n digits at s[pos..]; advances pos.
bool Digits(std::string_view s, std::size_t& pos, int n, int& out) {
  if (pos + n > s.size()) return false;
  int v = 0;
  for (int i = 0; i < n; ++i) {
    const char c = s[pos + i];
    if (!std::isdigit(static_cast<unsigned char>(c))) return false;
    v = v * 10 + (c - '0');
  }
  out = v;
  pos += n;
  return true;
}

bool Expect(std::string_view s, std::size_t& pos, std::string_view chars) {
  if (pos < s.size() && chars.find(s[pos]) != std::string_view::npos) {
    ++pos;
    return true;
  }
  return false;
}

int DaysInMonth(int y, int m) {
  static const int kDays[] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
  const bool leap = (y % 4 == 0 && y % 100 != 0) || y % 400 == 0;
  return m == 2 && leap ? 29 : kDays[m - 1];
}

}  // namespace

std::optional<double> ParseDateTime(std::string_view s) {
  s = TrimSpace(s);
  std::size_t p = 0;
  int y, mo, d, h, mi, sec;
  if (!Digits(s, p, 4, y) || !Expect(s, p, "-:./") || !Digits(s, p, 2, mo) ||
      !Expect(s, p, "-:./") || !Digits(s, p, 2, d) || !Expect(s, p, "T ") || !Digits(s, p, 2, h) ||
      !Expect(s, p, ":") || !Digits(s, p, 2, mi) || !Expect(s, p, ":") || !Digits(s, p, 2, sec)) {
    return std::nullopt;
  }
  if (mo < 1 || mo > 12 || d < 1 || d > DaysInMonth(y, mo) || h > 23 || mi > 59 || sec > 60) {
    return std::nullopt;
  }
  double frac = 0.0;
  if (p < s.size() && (s[p] == '.' || s[p] == ',')) {
    // ".123456" (ISO) or ",123,456" (DJI SRT: milliseconds, then microseconds).
    const bool dji = s[p] == ',';
    ++p;
    double scale = 0.1;
    std::size_t n = 0;
    while (p < s.size() &&
           (std::isdigit(static_cast<unsigned char>(s[p])) || (dji && s[p] == ',' && n == 3))) {
      if (s[p] != ',') {
        frac += (s[p] - '0') * scale;
        scale *= 0.1;
        ++n;
      }
      ++p;
    }
    if (n == 0) return std::nullopt;
  }
  double offset_s = 0.0;
  if (p < s.size()) {
    if (s[p] == 'Z' || s[p] == 'z') {
      ++p;
    } else if (s[p] == '+' || s[p] == '-') {
      const double sign = s[p] == '-' ? -1.0 : 1.0;
      ++p;
      int oh, om = 0;
      if (!Digits(s, p, 2, oh)) return std::nullopt;
      if (p < s.size()) {
        Expect(s, p, ":");
        if (!Digits(s, p, 2, om)) return std::nullopt;
      }
      if (oh > 23 || om > 59) return std::nullopt;
      offset_s = sign * (oh * 3600.0 + om * 60.0);
    }
  }
  if (p != s.size()) return std::nullopt;
  const double days = static_cast<double>(DaysFromCivil(y, mo, d));
  return days * 86400.0 + h * 3600.0 + mi * 60.0 + sec + frac - offset_s;
}

std::optional<double> ParseSrtClock(std::string_view s) {
  s = TrimSpace(s);
  std::size_t p = 0;
  int h, m, sec, ms;
  if (!Digits(s, p, 2, h) || !Expect(s, p, ":") || !Digits(s, p, 2, m) || !Expect(s, p, ":") ||
      !Digits(s, p, 2, sec) || !Expect(s, p, ",.") || !Digits(s, p, 3, ms) || p != s.size()) {
    return std::nullopt;
  }
  if (m > 59 || sec > 59) return std::nullopt;
  return h * 3600.0 + m * 60.0 + sec + ms / 1000.0;
}

namespace {

void AppendUtf8(char32_t cp, std::string& out) {
  if (cp < 0x80) {
    out.push_back(static_cast<char>(cp));
  } else if (cp < 0x800) {
    out.push_back(static_cast<char>(0xC0 | (cp >> 6)));
    out.push_back(static_cast<char>(0x80 | (cp & 0x3F)));
  } else if (cp < 0x10000) {
    out.push_back(static_cast<char>(0xE0 | (cp >> 12)));
    out.push_back(static_cast<char>(0x80 | ((cp >> 6) & 0x3F)));
    out.push_back(static_cast<char>(0x80 | (cp & 0x3F)));
  } else {
    out.push_back(static_cast<char>(0xF0 | (cp >> 18)));
    out.push_back(static_cast<char>(0x80 | ((cp >> 12) & 0x3F)));
    out.push_back(static_cast<char>(0x80 | ((cp >> 6) & 0x3F)));
    out.push_back(static_cast<char>(0x80 | (cp & 0x3F)));
  }
}

}  // namespace

std::string Utf16ToUtf8(std::string_view bytes, bool big_endian, const std::string& source) {
  if (bytes.size() % 2 != 0) {
    throw InputError(
        fmt::format("{}: UTF-16 text with an odd number of bytes ({}): the file is cut short",
                    source, bytes.size()));
  }
  const auto unit = [&](std::size_t k) -> char32_t {
    const auto a = static_cast<unsigned char>(bytes[2 * k]);
    const auto b = static_cast<unsigned char>(bytes[2 * k + 1]);
    return big_endian ? (char32_t{a} << 8 | b) : (char32_t{b} << 8 | a);
  };
  const std::size_t n = bytes.size() / 2;
  std::string out;
  out.reserve(n);
  for (std::size_t k = 0; k < n; ++k) {
    char32_t u = unit(k);
    if (u >= 0xD800 && u <= 0xDBFF && k + 1 < n && unit(k + 1) >= 0xDC00 && unit(k + 1) <= 0xDFFF) {
      u = 0x10000 + ((u - 0xD800) << 10) + (unit(k + 1) - 0xDC00);
      ++k;
    } else if (u >= 0xD800 && u <= 0xDFFF) {
      u = 0xFFFD;
    }
    AppendUtf8(u, out);
  }
  return out;
}

TextLines::TextLines(std::istream& in, std::string source) : in_(in), source_(std::move(source)) {
  // The byte-order marks: EF BB BF (UTF-8), FF FE / FE FF (UTF-16 LE / BE), FF FE 00 00 /
  // 00 00 FE FF (UTF-32 LE / BE): The Unicode Standard, section 23.8 "Specials", Table 23-4.
  std::streambuf* sb = in_.rdbuf();
  while (head_.size() < 4) {
    const int c = sb->sbumpc();
    if (c == std::char_traits<char>::eof()) break;
    head_.push_back(static_cast<char>(c));
  }
  const auto starts = [&](std::string_view bom) { return head_.rfind(bom, 0) == 0; };
  if (starts(std::string_view("\xFF\xFE\0\0", 4)) || starts(std::string_view("\0\0\xFE\xFF", 4))) {
    throw InputError(
        fmt::format("{}: the file is UTF-32 text (it starts with a UTF-32 "
                    "byte-order mark); save it as UTF-8",
                    source_));
  }
  if (starts("\xFF\xFE") || starts("\xFE\xFF")) {
    const bool big_endian = head_[0] == '\xFE';
    std::string raw = head_.substr(2);
    raw += ReadWholeText(in_, source_);
    decoded_ = Utf16ToUtf8(raw, big_endian, source_);
    use_decoded_ = true;
    head_.clear();
  } else if (starts("\xEF\xBB\xBF")) {
    head_.erase(0, 3);
  }
}

int TextLines::Get() {
  const std::string& buffered = use_decoded_ ? decoded_ : head_;
  if (pos_ < buffered.size()) return static_cast<unsigned char>(buffered[pos_++]);
  if (use_decoded_) return -1;
  const int c = in_.rdbuf()->sbumpc();
  return c == std::char_traits<char>::eof() ? -1 : c;
}

int TextLines::Peek() {
  const std::string& buffered = use_decoded_ ? decoded_ : head_;
  if (pos_ < buffered.size()) return static_cast<unsigned char>(buffered[pos_]);
  if (use_decoded_) return -1;
  const int c = in_.rdbuf()->sgetc();
  return c == std::char_traits<char>::eof() ? -1 : c;
}

bool TextLines::Next(std::string& line) {
  line.clear();
  int c = Get();
  if (c < 0) return false;
  ++line_;
  for (; c >= 0; c = Get()) {
    if (c == '\n') break;
    if (c == '\r') {
      if (Peek() == '\n') Get();
      break;
    }
    if (c == 0) {
      throw InputError(fmt::format(
          "{}:{}: a NUL byte at column {}: not a text file (binary data, or UTF-16/UTF-32 text "
          "without a byte-order mark; telemetry text is UTF-8)",
          source_, line_, line.size() + 1));
    }
    if (line.size() >= kMaxTextLineBytes) {
      throw InputError(
          fmt::format("{}:{}: a line longer than {} bytes: not a telemetry text "
                      "file",
                      source_, line_, kMaxTextLineBytes));
    }
    line.push_back(static_cast<char>(c));
  }
  return true;
}

std::string RecordErrors::At(long line) const { return fmt::format("{}:{}", source_, line); }

void RecordErrors::Report(long line, const std::string& message) {
  std::string full = fmt::format("{}:{}: {}", source_, line, message);
  if (!options_.lenient) throw MalformedRecordError(full);
  ++skipped_;
  if (static_cast<int>(warnings_.size()) < options_.max_warnings) {
    warnings_.push_back(std::move(full));
  }
}

void RecordErrors::ReportMessage(const std::string& full_message) {
  if (!options_.lenient) throw MalformedRecordError(full_message);
  ++skipped_;
  if (static_cast<int>(warnings_.size()) < options_.max_warnings) {
    warnings_.push_back(full_message);
  }
}

void RecordErrors::Note(std::string message) { notes_.push_back(std::move(message)); }

bool AcceptSample(const TelemetrySample& sample, long line, RecordErrors& errors) {
  try {
    ValidateSample(sample, errors.At(line));
    return true;
  } catch (const InputError& e) {
    errors.ReportMessage(e.what());
    return false;
  }
}

std::ifstream OpenInput(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    throw InputError(fmt::format("cannot open '{}': no such file", path.string()));
  }
  if (std::filesystem::is_directory(path, ec)) {
    throw InputError(fmt::format("cannot open '{}': is a directory", path.string()));
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw InputError(fmt::format("cannot open '{}': {}", path.string(), std::strerror(errno)));
  }
  return in;
}

namespace {

// Records that share a time but not a position come from a clock coarser than the records
// (whole-second dates on a 10 Hz log): spread over the clock's step (RepeatedTimeRun), with one
// warning naming the first run. Without any step (one time for every record) nothing places
// them: an error, unless frame indices do. Equal records (same time and position) stay as
// they are. Precondition: `samples` sorted by time_s.
void SpreadRepeatedTimes(std::vector<TelemetrySample>& samples, RecordErrors& errors,
                         const char* what) {
  std::vector<double> times(samples.size());
  for (std::size_t i = 0; i < samples.size(); ++i) times[i] = samples[i].time_s;
  int runs = 0, records = 0;
  std::string first;
  for (const RepeatedTimeRun& run : RepeatedTimeRuns(times)) {
    const TelemetrySample& a = samples[run.first];
    bool moves = false;
    for (std::size_t k = 1; k < run.count && !moves; ++k) {
      const TelemetrySample& b = samples[run.first + k];
      moves = b.lat_deg != a.lat_deg || b.lon_deg != a.lon_deg;
    }
    if (!moves) continue;
    const std::string where = a.origin.empty() ? errors.source() : a.origin;
    if (!(run.step_s > 0.0)) {
      const bool by_frame =
          std::all_of(samples.begin(), samples.end(),
                      [](const TelemetrySample& s) { return s.frame_index.has_value(); });
      if (by_frame) return;
      throw InputError(fmt::format(
          "{}: all {} records of this {} have the time {:.3f} s but not the same position: "
          "nothing places them in time (a finer time column, or a frame column, is needed)",
          where, run.count, what, run.time_s));
    }
    for (std::size_t k = 1; k < run.count; ++k) {
      TelemetrySample& s = samples[run.first + k];
      const double shift = SpreadTime(run, k) - run.time_s;
      s.time_s += shift;
      if (s.unix_time_s) *s.unix_time_s += shift;
    }
    if (runs == 0) {
      first = fmt::format(
          "{}: {} records share the time {:.3f} s but not the position (a clock coarser than "
          "the records): spread evenly over {:.3f}..{:.3f} s",
          where, run.count, run.time_s, run.time_s, run.time_s + run.step_s);
    }
    ++runs;
    records += static_cast<int>(run.count);
  }
  if (runs == 1) errors.Note(first);
  if (runs > 1) {
    errors.Note(fmt::format("{}; {} more such runs ({} records in all) spread the same way", first,
                            runs - 1, records));
  }
}

}  // namespace

TelemetryReadResult Finish(std::vector<TelemetrySample> samples, RecordErrors& errors,
                           int no_fix_records, const char* what) {
  if (samples.empty()) {
    throw InputError(
        fmt::format("{}: no telemetry samples in this {} ({} malformed, {} without "
                    "GPS fix)",
                    errors.source(), what, errors.skipped(), no_fix_records));
  }
  std::stable_sort(
      samples.begin(), samples.end(),
      [](const TelemetrySample& a, const TelemetrySample& b) { return a.time_s < b.time_s; });
  SpreadRepeatedTimes(samples, errors, what);
  TelemetryReadResult r;
  r.records = static_cast<int>(samples.size());
  r.skipped_records = errors.skipped();
  r.no_fix_records = no_fix_records;
  r.warnings = std::move(errors.warnings());
  r.warnings.insert(r.warnings.end(), errors.notes().begin(), errors.notes().end());
  r.telemetry = Telemetry(std::move(samples), errors.source());
  return r;
}

}  // namespace aerovo::io_detail

namespace aerovo {

std::string io_detail::ReadWholeText(std::istream& in, const std::string& source) {
  std::optional<std::string> text = ReadAtMost(in, kMaxWholeTextBytes);
  if (!text) {
    throw InputError(
        fmt::format("{}: more than {} MiB of text, not a telemetry file aerovo "
                    "reads whole (a GPX or UTF-16 text of a flight is megabytes)",
                    source, kMaxWholeTextBytes >> 20));
  }
  return std::move(*text);
}

void Validate(const TelemetryReadOptions& options) {
  if (options.max_warnings < 0) {
    throw InvalidArgument("TelemetryReadOptions.max_warnings must be >= 0");
  }
}

}  // namespace aerovo
