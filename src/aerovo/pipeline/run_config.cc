#include "aerovo/pipeline/run_config.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <type_traits>
#include <utility>

#include <fmt/format.h>
#include <yaml.h>

#include "aerovo/core/error.h"
#include "aerovo/geo/geo_point.h"
#include "aerovo/estimation/models.h"
#include "aerovo/odometry/georef.h"
#include "aerovo/odometry/pose_chain.h"

namespace aerovo {

// ---------------------------------------------------------------------------------------------
// Configuration

void Validate(const RunConfig& c) {
  auto fail = [](const std::string& m) { throw InvalidArgument("run configuration: " + m); };
  if (c.input.empty()) fail("'input' is required (video, image folder or live source)");
  if (c.out.empty()) fail("'out' must not be empty");
  if (c.step < 1) fail("'step' must be >= 1, got " + std::to_string(c.step));
  if (!(c.start_s >= 0.0)) fail("'start_s' must be >= 0");
  if (c.end_s >= 0.0 && c.end_s < c.start_s) fail("'end_s' must be >= 'start_s' (or < 0)");
  if (c.max_frames < 0) fail("'max_frames' must be >= 0");
  if (c.mode != "clustered" && c.mode != "standard") {
    fail("'mode' must be 'clustered' or 'standard', got '" + c.mode + "'");
  }
  if (c.matcher != "exhaustive" && c.matcher != "kdtree") {
    fail("'matcher' must be 'exhaustive' or 'kdtree', got '" + c.matcher + "'");
  }
  ParseMotionModel(c.model.c_str());
  ParseScaleMode(c.scale.c_str());
  ParseHeadingSource(c.heading);
  if (!(c.altitude_m >= 0.0) || !std::isfinite(c.altitude_m)) fail("'altitude_m' must be >= 0");
  if (!(c.focal_px >= 0.0) || !std::isfinite(c.focal_px)) fail("'focal_px' must be >= 0");
  if (!(c.hfov_deg >= 0.0 && c.hfov_deg < 180.0)) fail("'hfov_deg' must be in [0, 180)");
  if (c.min_inliers < 1) fail("'min_inliers' must be >= 1");
  if (!(c.surf_threshold >= 0.0)) fail("'surf_threshold' must be >= 0");
  if (c.max_keypoints < 0) fail("'max_keypoints' must be >= 0");
  if (c.threads < 0) fail("'threads' must be >= 0 (0 = all cores)");
  if (c.polish < 0) fail("'polish' must be >= 0 (0 = off)");
  for (double d : {c.k1, c.k2, c.p1, c.p2, c.k3}) {
    if (!std::isfinite(d)) fail("distortion coefficients must be finite");
  }
  if (!(c.illumination_k > 0.0 && c.illumination_k <= 1.0)) {
    fail(fmt::format("'illumination_k' must be in (0, 1], got {}", c.illumination_k));
  }
}

nlohmann::json ToJson(const RunConfig& c) {
  return nlohmann::json{{"input", c.input},
                        {"telemetry", c.telemetry},
                        {"lenient_telemetry", c.lenient_telemetry},
                        {"truth", c.truth},
                        {"out", c.out},
                        {"step", c.step},
                        {"start_s", c.start_s},
                        {"end_s", c.end_s},
                        {"max_frames", c.max_frames},
                        {"mode", c.mode},
                        {"model", c.model},
                        {"scale", c.scale},
                        {"heading", c.heading},
                        {"altitude_m", c.altitude_m},
                        {"focal_px", c.focal_px},
                        {"hfov_deg", c.hfov_deg},
                        {"k1", c.k1},
                        {"k2", c.k2},
                        {"p1", c.p1},
                        {"p2", c.p2},
                        {"k3", c.k3},
                        {"illumination_k", c.illumination_k},
                        {"guided", c.guided},
                        {"matcher", c.matcher},
                        {"refine", c.refine},
                        {"min_inliers", c.min_inliers},
                        {"surf_threshold", c.surf_threshold},
                        {"max_keypoints", c.max_keypoints},
                        {"seed", c.seed},
                        {"polish", c.polish},
                        {"threads", c.threads},
                        {"quiet", c.quiet}};
}

namespace {
template <class T>
void Take(const nlohmann::json& j, const char* key, T* out, const std::string& source) {
  auto it = j.find(key);
  if (it == j.end()) return;
  const auto wrong = [&](const std::string& why) {
    throw InvalidArgument(source + ": key '" + key + "' " + why);
  };
  if constexpr (std::is_integral_v<T> && !std::is_same_v<T, bool>) {
    // nlohmann's get<int>() static_casts whatever number it holds: 1e300 or -1 into an int or
    // a uint64 is undefined behaviour or a silent wrap-around. Only integers in T's range pass.
    if (it->is_number_unsigned()) {
      const auto v = it->template get<std::uint64_t>();
      if (v > static_cast<std::uint64_t>(std::numeric_limits<T>::max())) {
        wrong(
            fmt::format("value {} is out of range (at most {})", v, std::numeric_limits<T>::max()));
      }
      *out = static_cast<T>(v);
    } else if (it->is_number_integer()) {
      const auto v = it->template get<std::int64_t>();
      if (v < static_cast<std::int64_t>(std::numeric_limits<T>::min()) ||
          (std::is_signed_v<T> && v > static_cast<std::int64_t>(std::numeric_limits<T>::max()))) {
        wrong(fmt::format("value {} is out of range [{}, {}]", v, std::numeric_limits<T>::min(),
                          std::numeric_limits<T>::max()));
      }
      *out = static_cast<T>(v);
    } else {
      wrong(std::string("must be an integer, got ") + it->type_name() + " " +
            it->dump().substr(0, 40));
    }
  } else {
    try {
      *out = it->template get<T>();
    } catch (const nlohmann::json::exception& e) {
      wrong(std::string("has the wrong type (") + e.what() + ")");
    }
  }
}
}  // namespace

RunConfig RunConfigFromJson(const nlohmann::json& j, RunConfig c, const std::string& source) {
  if (!j.is_object()) throw InvalidArgument(source + ": the configuration must be a JSON object");
  const nlohmann::json known = ToJson(RunConfig{});
  for (auto it = j.begin(); it != j.end(); ++it) {
    if (!known.contains(it.key())) {
      throw InvalidArgument(source + ": unknown key '" + it.key() + "'");
    }
  }
  Take(j, "input", &c.input, source);
  Take(j, "telemetry", &c.telemetry, source);
  Take(j, "lenient_telemetry", &c.lenient_telemetry, source);
  Take(j, "truth", &c.truth, source);
  Take(j, "out", &c.out, source);
  Take(j, "step", &c.step, source);
  Take(j, "start_s", &c.start_s, source);
  Take(j, "end_s", &c.end_s, source);
  Take(j, "max_frames", &c.max_frames, source);
  Take(j, "mode", &c.mode, source);
  Take(j, "model", &c.model, source);
  Take(j, "scale", &c.scale, source);
  Take(j, "heading", &c.heading, source);
  Take(j, "altitude_m", &c.altitude_m, source);
  Take(j, "focal_px", &c.focal_px, source);
  Take(j, "hfov_deg", &c.hfov_deg, source);
  Take(j, "k1", &c.k1, source);
  Take(j, "k2", &c.k2, source);
  Take(j, "p1", &c.p1, source);
  Take(j, "p2", &c.p2, source);
  Take(j, "k3", &c.k3, source);
  Take(j, "illumination_k", &c.illumination_k, source);
  Take(j, "guided", &c.guided, source);
  Take(j, "matcher", &c.matcher, source);
  Take(j, "refine", &c.refine, source);
  Take(j, "min_inliers", &c.min_inliers, source);
  Take(j, "surf_threshold", &c.surf_threshold, source);
  Take(j, "max_keypoints", &c.max_keypoints, source);
  Take(j, "seed", &c.seed, source);
  Take(j, "polish", &c.polish, source);
  Take(j, "threads", &c.threads, source);
  Take(j, "quiet", &c.quiet, source);
  return c;
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
  errno = 0;
  const double d = std::strtod(v.c_str(), &end);
  if (end != v.c_str() && *end == '\0' && errno == 0 && std::isfinite(d)) return d;
  return v;
}

// Parses a flat YAML mapping (key: scalar) with libyaml into a JSON object.
nlohmann::json ParseFlatYaml(const std::string& text, const std::string& where) {
  yaml_parser_t parser;
  if (!yaml_parser_initialize(&parser)) throw InputError(where + ": cannot initialise libyaml");
  yaml_parser_set_input_string(&parser, reinterpret_cast<const unsigned char*>(text.data()),
                               text.size());
  nlohmann::json out = nlohmann::json::object();
  std::optional<std::string> key;
  int depth = 0;
  bool done = false;
  std::string error;
  while (!done && error.empty()) {
    yaml_event_t ev;
    if (!yaml_parser_parse(&parser, &ev)) {
      error = fmt::format("line {}: {}", parser.problem_mark.line + 1,
                          parser.problem ? parser.problem : "YAML syntax error");
      break;
    }
    switch (ev.type) {
      case YAML_MAPPING_START_EVENT:
        if (++depth > 1) error = "nested mappings are not allowed (flat key: value only)";
        break;
      case YAML_MAPPING_END_EVENT:
        --depth;
        break;
      case YAML_SEQUENCE_START_EVENT:
        error = fmt::format("line {}: lists are not allowed (flat key: value only)",
                            ev.start_mark.line + 1);
        break;
      case YAML_SCALAR_EVENT: {
        const std::string v(reinterpret_cast<const char*>(ev.data.scalar.value),
                            ev.data.scalar.length);
        if (depth != 1) {
          error = "the configuration must be a mapping of key: value";
        } else if (!key) {
          key = v;
        } else {
          out[*key] = YamlScalar(v, ev.data.scalar.style != YAML_PLAIN_SCALAR_STYLE);
          key.reset();
        }
        break;
      }
      case YAML_STREAM_END_EVENT:
        done = true;
        break;
      default:
        break;
    }
    yaml_event_delete(&ev);
  }
  yaml_parser_delete(&parser);
  if (!error.empty()) throw InputError(where + ": " + error);
  return out;
}

}  // namespace

RunConfig ParseRunConfig(std::string_view text, RunConfigFormat format, RunConfig base,
                         const std::string& source) {
  if (format == RunConfigFormat::kYaml) {
    return RunConfigFromJson(ParseFlatYaml(std::string(text), source), std::move(base), source);
  }
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text.begin(), text.end());
  } catch (const nlohmann::json::exception& e) {  // parse_error, and out_of_range for 1e340
    throw InputError(source + ": " + e.what());
  }
  return RunConfigFromJson(j, std::move(base), source);
}

RunConfig LoadRunConfig(const std::filesystem::path& path, RunConfig base) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError("cannot open config file '" + path.string() + "'");
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char ch) { return std::tolower(ch); });
  std::stringstream ss;
  ss << in.rdbuf();
  const RunConfigFormat format =
      ext == ".yaml" || ext == ".yml" ? RunConfigFormat::kYaml : RunConfigFormat::kJson;
  return ParseRunConfig(ss.str(), format, std::move(base), "config file '" + path.string() + "'");
}
}  // namespace aerovo
