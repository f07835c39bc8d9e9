// GPX tracks through pugixml. pugixml reports byte offsets; line numbers are recovered from
// the buffer so that messages name the line of the offending <trkpt>.
#include <algorithm>
#include <cstring>
#include <istream>
#include <iterator>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>
#include <pugixml.hpp>

#include "aerovo/telemetry/parse_util.h"
#include "aerovo/telemetry/telemetry_readers.h"

namespace aerovo {
namespace {

using io_detail::RecordErrors;

class LineIndex {
 public:
  explicit LineIndex(const std::string& text) {
    for (std::size_t i = 0; i < text.size(); ++i) {
      if (text[i] == '\n') newlines_.push_back(static_cast<std::ptrdiff_t>(i));
    }
  }
  long LineOf(std::ptrdiff_t offset) const {
    if (offset < 0) return 0;
    return 1 + static_cast<long>(std::lower_bound(newlines_.begin(), newlines_.end(), offset) -
                                 newlines_.begin());
  }

 private:
  std::vector<std::ptrdiff_t> newlines_;
};

// Element name without a namespace prefix ("gpx:trkpt" -> "trkpt").
const char* LocalName(const pugi::xml_node& n) {
  const char* name = n.name();
  const char* colon = std::strrchr(name, ':');
  return colon ? colon + 1 : name;
}

pugi::xml_node Child(const pugi::xml_node& n, const char* local) {
  for (pugi::xml_node c = n.first_child(); c; c = c.next_sibling()) {
    if (c.type() == pugi::node_element && std::strcmp(LocalName(c), local) == 0) return c;
  }
  return {};
}

// Document-order walk without recursion (a hostile file may nest elements very deeply).
// Elements named `local` are collected and not descended into.
void Collect(const pugi::xml_node& root, const char* local, std::vector<pugi::xml_node>& out) {
  pugi::xml_node n = root.first_child();
  while (n && n != root) {
    bool descend = false;
    if (n.type() == pugi::node_element) {
      if (std::strcmp(LocalName(n), local) == 0) {
        out.push_back(n);
      } else {
        descend = true;
      }
    }
    if (descend && n.first_child()) {
      n = n.first_child();
      continue;
    }
    while (n && n != root && !n.next_sibling()) n = n.parent();
    if (!n || n == root) break;
    n = n.next_sibling();
  }
}

struct ParsedPoint {
  TelemetrySample sample;
  long line;
  bool has_time;
};

// One <trkpt>/<rtept> at `line`: its sample (time_s not yet set), or nullopt when it is
// malformed (reported through `errors`), has no GPS fix (counted in no_fix) or fails
// AcceptSample.
std::optional<ParsedPoint> ParsePoint(const pugi::xml_node& pt, long line, RecordErrors& errors,
                                      int& no_fix) {
  const pugi::xml_attribute lat_a = pt.attribute("lat");
  const pugi::xml_attribute lon_a = pt.attribute("lon");
  if (!lat_a || !lon_a) {
    errors.Report(line,
                  fmt::format("<{}> without {} attribute", pt.name(), !lat_a ? "a lat" : "a lon"));
    return std::nullopt;
  }
  const auto lat = ParseDecimal(lat_a.value());
  const auto lon = ParseDecimal(lon_a.value());
  if (!lat || !lon) {
    errors.Report(line, fmt::format("{} '{}' is not a number", !lat ? "lat" : "lon",
                                    Printable(!lat ? lat_a.value() : lon_a.value())));
    return std::nullopt;
  }
  TelemetrySample s;
  s.lat_deg = *lat;
  s.lon_deg = *lon;
  if (const pugi::xml_node ele = Child(pt, "ele")) {
    const auto v = ParseDecimal(ele.text().get());
    if (!v) {
      errors.Report(line, fmt::format("<ele> '{}' is not a number", Printable(ele.text().get())));
      return std::nullopt;
    }
    s.abs_alt_m = v;
  }
  bool has_time = false;
  if (const pugi::xml_node t = Child(pt, "time")) {
    const auto v = io_detail::ParseDateTime(t.text().get());
    if (!v) {
      errors.Report(line,
                    fmt::format("<time> '{}' is not an ISO 8601 date", Printable(t.text().get())));
      return std::nullopt;
    }
    s.unix_time_s = v;
    has_time = true;
  }
  if (const pugi::xml_node c = Child(pt, "course")) {  // GPX 1.0 heading
    if (auto v = ParseDecimal(c.text().get())) s.yaw_deg = v;
  }
  if (*lat == 0.0 && *lon == 0.0) {
    ++no_fix;
    return std::nullopt;
  }
  if (!io_detail::AcceptSample(s, line, errors)) return std::nullopt;
  s.origin = errors.At(line);
  return ParsedPoint{s, line, has_time};
}

}  // namespace

TelemetryReadResult ParseGpx(std::istream& in, const std::string& source_name,
                             const TelemetryReadOptions& options) {
  Validate(options);
  RecordErrors errors(options, source_name);
  std::string text = io_detail::ReadWholeText(in, source_name);
  // UTF-16 (with a byte-order mark, or without one: a document starting "<?" in UTF-16, XML 1.0
  // Appendix F.1) is transcoded here rather than by pugixml, so that the line numbers count the
  // lines of the text (pugixml's offsets are those of its own UTF-8 copy: a UTF-16 file's
  // errors were put at half their line).
  pugi::xml_encoding encoding = pugi::encoding_auto;
  const auto starts = [&](std::string_view prefix) { return text.rfind(prefix, 0) == 0; };
  if (starts("\xFF\xFE") || starts("\xFE\xFF")) {
    text = io_detail::Utf16ToUtf8(std::string_view(text).substr(2), text[0] == '\xFE', source_name);
    encoding = pugi::encoding_utf8;
  } else if (starts(std::string_view("<\0?\0", 4)) || starts(std::string_view("\0<\0?", 4))) {
    text = io_detail::Utf16ToUtf8(text, text[0] == '\0', source_name);
    encoding = pugi::encoding_utf8;
  }
  const LineIndex lines(text);
  pugi::xml_document doc;
  // parse_default without entity/EOL conversions we do not need; pugixml never fetches
  // external entities, so hostile files cannot make it read other files.
  const pugi::xml_parse_result parsed =
      doc.load_buffer(text.data(), text.size(), pugi::parse_default, encoding);
  // A document that stops before its end (a logger or an app whose writing stopped: the battery,
  // a crash, a partial copy): pugixml fails where the text runs out (an element left open, or a
  // tag, attribute or text cut), no markup ends after that place, and the tree up to it is kept
  // (pugixml manual, "Handling parsing errors": "you can use the part of the tree that was
  // successfully parsed"). Such a GPX is read up to the cut, its last point dropped when the
  // cut falls inside it, with a warning, in both modes; an error before the end stays an error.
  const bool cut = !parsed && parsed.offset >= 0 &&
                   text.find('>', static_cast<std::size_t>(parsed.offset) + 1) == std::string::npos;
  if (!parsed && !cut) {
    throw InputError(fmt::format("{}:{}: XML error: {}", source_name, lines.LineOf(parsed.offset),
                                 parsed.description()));
  }
  pugi::xml_node root = doc.document_element();
  if (!root || std::strcmp(LocalName(root), "gpx") != 0) {
    if (cut) {
      throw InputError(fmt::format("{}:{}: XML error: {} (the file ends before its <gpx> element)",
                                   source_name, lines.LineOf(parsed.offset), parsed.description()));
    }
    throw InputError(fmt::format("{}: not a GPX file (root element is <{}>)", source_name,
                                 Printable(root ? root.name() : "")));
  }
  std::vector<pugi::xml_node> points;
  Collect(root, "trkpt", points);
  if (points.empty()) Collect(root, "rtept", points);
  if (cut) {
    // The last point is whole when its end tag (or the "/>" of an empty element) is in the text.
    bool dropped = false;
    if (!points.empty()) {
      const pugi::xml_node last = points.back();
      const std::size_t at =
          static_cast<std::size_t>(std::max<std::ptrdiff_t>(0, last.offset_debug()));
      const std::size_t tag_end = text.find('>', at);
      const bool empty_element =
          tag_end != std::string::npos && tag_end > at && text[tag_end - 1] == '/';
      const bool closed = text.find(fmt::format("</{}>", last.name()), at) != std::string::npos;
      if (!empty_element && !closed) {
        points.pop_back();
        dropped = true;
      }
    }
    errors.Note(fmt::format(
        "{}:{}: the file ends before the end of its GPX document ({}: a log whose writing "
        "stopped): read up to there{}",
        source_name, lines.LineOf(parsed.offset), parsed.description(),
        dropped ? ", the point cut there dropped" : ""));
  }

  std::vector<ParsedPoint> parsed_points;
  int no_fix = 0;
  for (const pugi::xml_node& pt : points) {
    const long line = lines.LineOf(pt.offset_debug());
    if (auto p = ParsePoint(pt, line, errors, no_fix)) parsed_points.push_back(*p);
  }

  const bool any_time = std::any_of(parsed_points.begin(), parsed_points.end(),
                                    [](const ParsedPoint& p) { return p.has_time; });
  std::vector<TelemetrySample> samples;
  if (!any_time) {
    if (!parsed_points.empty()) {
      errors.Note(
          fmt::format("{}: no <time> in any point: time_s is the point's rank", source_name));
    }
    for (std::size_t k = 0; k < parsed_points.size(); ++k) {
      parsed_points[k].sample.time_s = static_cast<double>(k);
      samples.push_back(parsed_points[k].sample);
    }
    return io_detail::Finish(std::move(samples), errors, no_fix, "GPX file");
  }
  std::optional<double> t0, last;
  for (ParsedPoint& p : parsed_points) {
    if (!p.has_time) {
      errors.Report(p.line, "point without <time> in a track whose other points have one");
      continue;
    }
    const double t = *p.sample.unix_time_s;
    if (last && t < *last) {
      errors.Report(p.line, fmt::format("<time> is {:.3f} s earlier than the previous point's "
                                        "(timestamps out of order)",
                                        *last - t));
      continue;
    }
    if (!t0) t0 = t;
    last = t;
    p.sample.time_s = t - *t0;
    samples.push_back(p.sample);
  }
  return io_detail::Finish(std::move(samples), errors, no_fix, "GPX file");
}

TelemetryReadResult ReadGpx(const std::filesystem::path& path,
                            const TelemetryReadOptions& options) {
  std::ifstream in = io_detail::OpenInput(path);
  return ParseGpx(in, path.string(), options);
}

}  // namespace aerovo
