#include "aerovo/pipeline/run_config.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <system_error>
#include <type_traits>
#include <utility>

#include <fmt/format.h>

#include "aerovo/core/error.h"
#include "aerovo/core/options_json.h"
#include "aerovo/core/text.h"
#include "aerovo/mavlink/transport.h"
#include "aerovo/yaml/yaml_events.h"

namespace aerovo {

// ---------------------------------------------------------------------------------------------
// Configuration

const std::vector<RunShorthand>& RunShorthands() {
  // The one table of shorthands: a new key a shorthand must also set is one more entry here.
  static const std::vector<RunShorthand> shorthands = {
      {"threads",
       "Threads for SURF and matching (0 = all cores)",
       {"surf.num_threads", "match.num_threads"}},
  };
  return shorthands;
}

void ApplyPaperPreset(RunConfig& c) {
  c.odometry.surf.adaptive = false;
  c.odometry.correspondence.guided_matching = false;
  c.odometry.correspondence.clustered.refine = false;
  c.attitude = AttitudeMode::kOff;
  c.lens_estimation = LensEstimationMode::kOff;
  c.attitude_estimation = AttitudeEstimationMode::kOff;
  c.flat_field.mode = FlatFieldMode::kOff;
}

RunConfig PaperRunConfig() {
  RunConfig c;
  ApplyPaperPreset(c);
  return c;
}

const std::vector<RunPreset>& RunPresets() {
  static const std::vector<RunPreset> presets = {
      {"paper",
       "The paper's exact pipeline (Ivanov & Muzychuk 2023, MATLAB semantics): SURF with the fixed "
       "threshold of detectSURFFeatures (surf.hessian_threshold, default 1000), every frame "
       "matched exhaustively, the clustered RANSAC's best cell fit as it is; what `aerovo "
       "experiment --paper` uses to reproduce the paper's figures; no attitude correction (the "
       "paper's nadir camera), no lens or tilt self-calibration, no flat-field correction",
       {{"surf.adaptive", "false"},
        {"correspondence.guided_matching", "false"},
        {"clustered.refine", "false"},
        {"attitude", "off"},
        {"lens_estimation", "off"},
        {"attitude_estimation", "off"},
        {"flat_field.mode", "off"}}},
  };
  return presets;
}

void Validate(const RunConfig& c) {
  const std::string context = "run configuration";
  const auto fail = [&](const std::string& m) { throw InvalidArgument(context + ": " + m); };
  if (c.input.empty()) fail("input is required (video, image folder or live source)");
  if (c.out.empty()) fail("out must not be empty");
  options::CheckRanges(c, "", false, context);
  if (c.end_s >= 0.0 && c.end_s < c.start_s) fail("end_s must be >= start_s (or < 0)");
  if (!c.mavlink.empty()) {
    try {
      mavlink::ParseLinkUrl(c.mavlink);
    } catch (const InvalidArgument& e) {
      fail(e.what());
    }
  }
  if (c.sensor_aspect != 0.0 && c.sensor_aspect < 1.0) {
    fail("sensor_aspect " + options::FormatNumber(c.sensor_aspect) +
         " must be 0 (automatic) or in [1, 4] (long side / short side, e.g. 1.3333 for 4:3)");
  }
  if (!c.calibration.empty() &&
      (c.k1 != 0.0 || c.k2 != 0.0 || c.p1 != 0.0 || c.p2 != 0.0 || c.k3 != 0.0)) {
    fail("calibration '" + c.calibration +
         "' gives the lens distortion: leave k1, k2, p1, p2, k3 at 0 with it");
  }
  if (c.focal_px > 0.0 && c.focal_px < 1.0) {
    fail("focal_px must be 0 (unknown) or at least 1 px, got " + options::FormatNumber(c.focal_px));
  }
  if (!std::isnan(c.ground_elevation_m) && !(std::abs(c.ground_elevation_m) <= 1e4)) {
    fail("ground_elevation_m must be nan (unknown) or in [-10000, 10000] m, got " +
         options::FormatNumber(c.ground_elevation_m));
  }
  try {
    Validate(c.gps_check);
    Validate(c.flat_field);
    Validate(c.backend);
    Validate(c.odometry);
    Validate(c.map_fix);
  } catch (const InvalidArgument& e) {
    fail(e.what());
  }
}

nlohmann::json ToJson(const RunConfig& c) {
  nlohmann::json j = options::ToFlatJson(c);
  // NaN (ground_elevation_m: unknown) as an explicit null: written the same, equal to itself,
  // read back as NaN.
  for (auto& [key, value] : j.items()) {
    if (value.is_number_float() && std::isnan(value.get<double>())) value = nullptr;
  }
  return j;
}

namespace {

// {"ransac": {"seed": 2}} -> {"ransac.seed": 2}; "resolved" stays as it is.
void Flatten(const nlohmann::json& j, const std::string& prefix, nlohmann::json* out) {
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string key = prefix + it.key();
    if (it->is_object() && !(prefix.empty() && it.key() == "resolved")) {
      Flatten(*it, key + ".", out);
    } else {
      (*out)[key] = *it;
    }
  }
}

}  // namespace

RunConfig RunConfigFromJson(const nlohmann::json& given, RunConfig c, const std::string& source) {
  if (!given.is_object()) {
    throw InvalidArgument(source + ": the configuration must be a JSON object");
  }
  nlohmann::json j = nlohmann::json::object();
  Flatten(given, "", &j);
  if (j.contains("resolved") && !j["resolved"].is_object()) {
    throw InvalidArgument(source +
                          ": key 'resolved' (what a run resolved, ignored) must be an object");
  }
  std::multimap<std::string, std::string> also;
  for (const RunShorthand& s : RunShorthands()) {
    for (const char* key : s.keys) also.emplace(key, s.name);
  }
  options::JsonReader reader(j, source, &also);
  VisitFields(c, reader);
  for (auto it = j.begin(); it != j.end(); ++it) {
    if (it.key() != "resolved" && reader.known().count(it.key()) == 0) {
      throw InvalidArgument(source + ": unknown key '" + it.key() +
                            "' (aerovo run --list-options lists every key)");
    }
  }
  return c;
}

std::string RunOptionsMarkdown() {
  std::string md =
      "# Options of `aerovo run`\n\n"
      "Generated by `aerovo run --list-options` from the option schema (the `VisitFields` lists "
      "beside each options struct's `Validate`; core/options.h). Every option is a key of a "
      "JSON or YAML config file (`--config`; flat keys, the dotted ones included) and a flag; "
      "a run saves its configuration as `config.json` with the canonical keys, and "
      "`--config OUT/config.json` reproduces it. The legacy short keys in parentheses (and "
      "their flags) still work; giving two names of one option with different values is an "
      "error.\n\n";
  md += options::MarkdownTable(options::ListFields(RunConfig{}));
  md += "\n## Shorthands\n\nOne key or flag for several options.\n\n";
  md += "| Key | Flag | Sets | Description |\n|---|---|---|---|\n";
  for (const RunShorthand& s : RunShorthands()) {
    std::string keys;
    for (const char* k : s.keys) keys += std::string(keys.empty() ? "" : ", ") + "`" + k + "`";
    md += std::string("| `") + s.name + "` | `" + options::FlagName(s.name) + "` | " + keys +
          " | " + s.doc + " |\n";
  }
  md +=
      "\n## Presets\n\nA flag that starts from other defaults; options given with it (flags, "
      "`--config`) still win.\n\n";
  md += "| Flag | Sets | Description |\n|---|---|---|\n";
  for (const RunPreset& p : RunPresets()) {
    std::string keys;
    for (const auto& [k, v] : p.sets) {
      keys += std::string(keys.empty() ? "" : ", ") + "`" + k + " = " + v + "`";
    }
    md += std::string("| `--") + p.name + "` | " + keys + " | " + p.doc + " |\n";
  }
  return md;
}

namespace {

// A YAML scalar as the JSON value it most plausibly means (the config is flat: numbers, booleans,
// strings); quoted scalars stay strings.
nlohmann::json YamlScalar(const std::string& v, bool quoted) {
  if (quoted) return v;
  if (v == "true" || v == "yes" || v == "on") return true;
  if (v == "false" || v == "no" || v == "off") return false;
  if (v == "~" || v == "null" || v.empty()) return nullptr;
  // Numbers that overflow their type are not clamped (strtoll would give LLONG_MAX): an integer
  // too large for int64 goes on as uint64 or else as a double (then "must be an integer" for an
  // integer key), and a double out of range stays a string ("wrong type").
  char* end = nullptr;
  errno = 0;
  const long long i = std::strtoll(v.c_str(), &end, 10);
  if (end != v.c_str() && *end == '\0' && errno == 0) return i;
  if (v[0] != '-') {
    errno = 0;
    const unsigned long long u = std::strtoull(v.c_str(), &end, 10);
    if (end != v.c_str() && *end == '\0' && errno == 0) return u;
  }
  if (const std::optional<double> d = ParseDecimal(v)) return *d;  // no hex, nan, inf (core/text.h)
  return v;
}

// Reads a YAML document with libyaml into JSON: scalars (YamlScalar), mappings, sequences,
// anchors (&a) and aliases (*a), and merge keys (`<<: *a`, `<<: [*a, *b]`, `<<: {k: v}`; keys
// of the mapping itself win, then the first merged mapping: YAML 1.1 merge key type).
// A hostile file is bounded: nesting deeper than kMaxDepth (the reader recurses per level: a
// line of 20000 '[' overflowed the stack) and a document whose values, aliases expanded, exceed
// kMaxValues (aliases of aliases grow exponentially: 9 levels of 10 aliases each are 10^9
// values, which took 4.5 GB and did not end) are errors naming the line.
class YamlReader {
 public:
  /// A flat configuration nests 2 levels (a template mapping, a list); far above any real file.
  static constexpr int kMaxDepth = 64;
  /// Values (scalars, mappings, sequences) with every alias expanded; a configuration has a few
  /// hundred.
  static constexpr std::size_t kMaxValues = 100000;

  YamlReader(const std::string& text, std::string where) : events_(text, std::move(where)) {}

  // The flat configuration: a mapping of key: scalar. A top-level key whose value is an
  // anchored mapping only used by merge keys is a template (e.g. `.base: &base {...}`) and is
  // not part of the configuration; any other nested mapping or list is an error.
  nlohmann::json ReadFlat() {
    std::optional<YamlEvent> top =
        events_.TopMapping("the configuration must be a mapping of key: value");
    if (!top) return nlohmann::json::object();
    const nlohmann::json root = Node(*top, /*top=*/true);
    events_.ExpectEnd("only one YAML document is allowed");
    nlohmann::json out = nlohmann::json::object();
    for (auto it = root.begin(); it != root.end(); ++it) {
      const auto line = top_lines_.find(it.key());
      const int at = line != top_lines_.end() ? line->second : 0;
      if (it->is_object()) {
        const auto anchor = top_anchors_.find(it.key());
        if (anchor != top_anchors_.end() && merged_anchors_.count(anchor->second) > 0) continue;
        throw events_.Error(
            at, fmt::format("'{}': nested mappings are not allowed (flat key: value only; a "
                            "mapping with an anchor used by a merge key `<<: *name` is allowed "
                            "as a template)",
                            it.key()));
      }
      // A list of scalars is a list option's value (`map: [a.tif, b.tif]`; the schema rejects
      // it for any other key, naming the key); nothing deeper.
      const auto nested = [](const nlohmann::json& e) { return e.is_array() || e.is_object(); };
      if (it->is_array() && std::any_of(it->begin(), it->end(), nested)) {
        throw events_.Error(at, fmt::format("'{}': lists of lists or mappings are not allowed "
                                            "(flat key: value, or a list of values)",
                                            it.key()));
      }
      out[it.key()] = *it;
    }
    return out;
  }

 private:
  static std::string Str(const yaml_char_t* s) {
    return s != nullptr ? std::string(reinterpret_cast<const char*>(s)) : std::string();
  }

  void Anchor(const yaml_char_t* anchor, const nlohmann::json& value) {
    if (anchor != nullptr) anchors_[Str(anchor)] = value;
  }

  // The mapping starting at `ev` (its keys in order; merge keys << applied after them).
  nlohmann::json Mapping(const YamlEvent& ev, bool top) {
    const std::string anchor = Str(ev.e.data.mapping_start.anchor);
    nlohmann::json obj = nlohmann::json::object();
    std::vector<nlohmann::json> merges;
    for (;;) {
      const YamlEvent k = events_.Next();
      if (k.e.type == YAML_MAPPING_END_EVENT) break;
      if (k.e.type != YAML_SCALAR_EVENT) throw events_.Error(k, "a key must be a plain scalar");
      const std::string key(k.scalar());
      const bool is_merge = key == "<<" && k.plain();
      const int line = k.line();
      const YamlEvent v = events_.Next();
      const bool anchored_mapping =
          v.e.type == YAML_MAPPING_START_EVENT && v.e.data.mapping_start.anchor != nullptr;
      const std::string value_anchor =
          anchored_mapping ? Str(v.e.data.mapping_start.anchor) : std::string();
      nlohmann::json value = Node(v, false, is_merge);
      if (is_merge) {
        const auto check = [&](const nlohmann::json& m) {
          if (!m.is_object()) {
            throw events_.Error(line, "a merge key << takes a mapping or a list of mappings");
          }
        };
        if (value.is_array()) {
          for (const auto& m : value) check(m), merges.push_back(m);
        } else {
          check(value);
          merges.push_back(value);
        }
        continue;
      }
      if (obj.contains(key)) {
        throw events_.Error(line, fmt::format("key '{}' is given twice", key));
      }
      obj[key] = std::move(value);
      if (top) {
        top_lines_[key] = line;
        if (anchored_mapping) top_anchors_[key] = value_anchor;
      }
    }
    // Explicit keys win over merged ones; among merged mappings the first wins.
    for (const nlohmann::json& m : merges) {
      for (auto it = m.begin(); it != m.end(); ++it) {
        if (!obj.contains(it.key())) obj[it.key()] = *it;
      }
    }
    if (!anchor.empty()) anchors_[anchor] = obj;
    return obj;
  }

  // The value starting at `ev` (a scalar, an alias, a mapping or a sequence start).
  nlohmann::json Node(const YamlEvent& ev, bool top = false, bool merge_value = false) {
    switch (ev.e.type) {
      case YAML_SCALAR_EVENT: {
        Count(ev, 1);
        nlohmann::json j = YamlScalar(std::string(ev.scalar()), !ev.plain());
        Anchor(ev.e.data.scalar.anchor, j);
        return j;
      }
      case YAML_ALIAS_EVENT: {
        const std::string name = Str(ev.e.data.alias.anchor);
        const auto it = anchors_.find(name);
        if (it == anchors_.end())
          throw events_.Error(ev, "alias *" + name + " names no anchor before it");
        if (merge_value) merged_anchors_.insert(name);
        Count(ev, ValuesIn(it->second));
        return it->second;
      }
      case YAML_SEQUENCE_START_EVENT: {
        const Nesting nesting(this, ev);
        const yaml_char_t* anchor_ptr = ev.e.data.sequence_start.anchor;
        const std::string anchor = Str(anchor_ptr);
        nlohmann::json arr = nlohmann::json::array();
        for (;;) {
          const YamlEvent item = events_.Next();
          if (item.e.type == YAML_SEQUENCE_END_EVENT) break;
          arr.push_back(Node(item, false, merge_value));
        }
        if (!anchor.empty()) anchors_[anchor] = arr;
        return arr;
      }
      case YAML_MAPPING_START_EVENT: {
        const Nesting nesting(this, ev);
        return Mapping(ev, top);
      }
      default:
        throw events_.Error(ev, "unexpected YAML event");
    }
  }

  // One level of nesting (a mapping or a sequence) for as long as it lives; counts as a value.
  class Nesting {
   public:
    Nesting(YamlReader* reader, const YamlEvent& ev) : reader_(reader) {
      if (++reader_->depth_ > kMaxDepth) {
        throw reader_->events_.Error(ev,
                                     fmt::format("nested deeper than {} levels (a configuration is "
                                                 "flat: key: value, or a list of values)",
                                                 kMaxDepth));
      }
      reader_->Count(ev, 1);
    }
    ~Nesting() { --reader_->depth_; }
    Nesting(const Nesting&) = delete;
    Nesting& operator=(const Nesting&) = delete;

   private:
    YamlReader* reader_;
  };

  // Values in `j` (itself, its elements and members, recursively) without building anything.
  static std::size_t ValuesIn(const nlohmann::json& j) {
    std::size_t n = 1;
    if (j.is_structured()) {
      for (const auto& e : j) n += ValuesIn(e);
    }
    return n;
  }

  void Count(const YamlEvent& ev, std::size_t n) {
    values_ += n;
    if (values_ > kMaxValues) {
      throw events_.Error(ev,
                          fmt::format("the document holds more than {} values with its aliases "
                                      "expanded (aliases of aliases?); a configuration holds a few "
                                      "hundred",
                                      kMaxValues));
    }
  }

  YamlEvents events_;
  int depth_ = 0;
  std::size_t values_ = 0;
  std::map<std::string, nlohmann::json> anchors_;
  std::set<std::string> merged_anchors_;
  std::map<std::string, std::string> top_anchors_;  // top-level key -> anchor of its mapping
  std::map<std::string, int> top_lines_;

 public:
  /// The line (1-based) of each top-level key read by ReadFlat.
  const std::map<std::string, int>& top_lines() const { return top_lines_; }
};

// A flat YAML mapping (key: scalar or list of scalars, with anchors, aliases and merge keys)
// as a RunConfig over `base`: a value the schema rejects (RunConfigFromJson's InvalidArgument
// naming the key) is an InvalidArgument naming the file and the key's line too (a bad value,
// as on the command line; a YAML syntax or structure error is an InputError).
RunConfig RunConfigFromYaml(const std::string& text, RunConfig base, const std::string& where) {
  YamlReader reader(text, where);
  const nlohmann::json j = reader.ReadFlat();
  try {
    return RunConfigFromJson(j, std::move(base), where);
  } catch (const InvalidArgument& e) {
    const std::string what = e.what();
    for (const auto& [key, line] : reader.top_lines()) {
      if (what.find("'" + key + "'") == std::string::npos) continue;
      const std::string prefix = where + ": ";
      const std::string rest = what.rfind(prefix, 0) == 0 ? what.substr(prefix.size()) : what;
      throw InvalidArgument(fmt::format("{}: line {}: {}", where, line, rest));
    }
    throw;
  }
}

}  // namespace

RunConfig ParseRunConfig(std::string_view text, RunConfigFormat format, RunConfig base,
                         const std::string& source) {
  if (format == RunConfigFormat::kYaml) {
    return RunConfigFromYaml(std::string(text), std::move(base), source);
  }
  // JSON text is UTF-8 (RFC 8259 section 8.1); a UTF-16 file (a Windows editor's "Unicode")
  // is said to be one rather than shown as a syntax error at its first byte.
  if (text.rfind("\xFF\xFE", 0) == 0 || text.rfind("\xFE\xFF", 0) == 0) {
    throw InputError(source +
                     ": the file is UTF-16 text (it starts with a UTF-16 byte-order mark); a "
                     "JSON configuration is UTF-8 (RFC 8259): save it as UTF-8");
  }
  // A key given twice in one object: RFC 8259 section 4 leaves its meaning to the reader
  // (nlohmann-json keeps the last). A flag given twice is an error, and so is a YAML key given
  // twice; so is a JSON one.
  std::vector<std::set<std::string>> keys_of_open_objects;
  const nlohmann::json::parser_callback_t check_keys =
      [&](int /*depth*/, nlohmann::json::parse_event_t event, nlohmann::json& parsed) {
        using Event = nlohmann::json::parse_event_t;
        if (event == Event::object_start) {
          keys_of_open_objects.emplace_back();
        } else if (event == Event::object_end && !keys_of_open_objects.empty()) {
          keys_of_open_objects.pop_back();
        } else if (event == Event::key && !keys_of_open_objects.empty() &&
                   !keys_of_open_objects.back().insert(parsed.get<std::string>()).second) {
          throw InputError(fmt::format("{}: key '{}' is given twice in one object", source,
                                       parsed.get<std::string>()));
        }
        return true;
      };
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text.begin(), text.end(), check_keys);
  } catch (const nlohmann::json::exception& e) {  // parse_error, and out_of_range for 1e340
    throw InputError(source + ": " + e.what());
  }
  return RunConfigFromJson(j, std::move(base), source);
}

RunConfig LoadRunConfig(const std::filesystem::path& path, RunConfig base) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError("cannot open config file '" + path.string() + "'");
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    throw InputError("config file '" + path.string() + "': a folder, not a configuration file");
  }
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char ch) { return std::tolower(ch); });
  // A configuration is a few kilobytes; a larger file (or a device, /dev/zero) is not one.
  constexpr std::size_t kMaxConfigBytes = std::size_t{16} << 20;
  const std::optional<std::string> text = ReadAtMost(in, kMaxConfigBytes);
  if (!text) {
    throw InputError(
        fmt::format("config file '{}': more than {} MiB, not a configuration file "
                    "(aerovo's are a few kilobytes)",
                    path.string(), kMaxConfigBytes >> 20));
  }
  const RunConfigFormat format =
      ext == ".yaml" || ext == ".yml" ? RunConfigFormat::kYaml : RunConfigFormat::kJson;
  const std::string source = "config file '" + path.string() + "'";
  RunConfig config = ParseRunConfig(*text, format, std::move(base), source);
  // Each value's range checked here too, so that one out of its range names the file it is in
  // ("config file 'c.json': surf.num_threads must be in [0, 256], got 100000"); Validate checks
  // the merged configuration again, with the rules between options.
  options::CheckRanges(config, "", /*recurse=*/true, source);
  return config;
}
}  // namespace aerovo
