// JSON writer and reader of the option field lists (core/options.h): flat objects whose keys are
// the fields' dotted keys ("ransac.max_distance_px"). Needs nlohmann_json (header-only).
#pragma once

#include <cstdint>
#include <cstdlib>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <type_traits>
#include <vector>

#include <nlohmann/json.hpp>

#include "aerovo/core/error.h"
#include "aerovo/core/options.h"

namespace aerovo::options {

/// A field's value as JSON: enums by name; a float as the shortest decimal that reads back as
/// the same float (0.6f is written 0.6, not 0.6000000238418579).
template <class T>
nlohmann::json ToJsonValue(const T& v) {
  if constexpr (std::is_enum_v<T>) {
    return EnumName(v);
  } else if constexpr (std::is_same_v<T, float>) {
    if (!std::isfinite(v)) return static_cast<double>(v);  // nlohmann writes null
    return std::strtod(FormatNumber(v).c_str(), nullptr);
  } else {
    return v;
  }
}

/// `j` read as a T. InvalidArgument "<source>: key '<name>' ..." for a value of the wrong type
/// or, for integers and floats, out of T's range (nlohmann's get<int>() would static_cast 1e300
/// or -1 into an int or uint64: undefined behaviour or a silent wrap-around).
template <class T>
T FromJsonValue(const nlohmann::json& j, const std::string& name, const std::string& source) {
  const auto wrong = [&](const std::string& why) -> T {
    throw InvalidArgument(source + ": key '" + name + "' " + why);
  };
  const auto got = [&] { return std::string(j.type_name()) + " " + j.dump().substr(0, 40); };
  if constexpr (std::is_same_v<T, bool>) {
    if (!j.is_boolean()) return wrong("must be a boolean (true or false), got " + got());
    return j.get<bool>();
  } else if constexpr (std::is_integral_v<T>) {
    if (j.is_number_unsigned()) {
      const auto v = j.get<std::uint64_t>();
      if (v > static_cast<std::uint64_t>(std::numeric_limits<T>::max())) {
        return wrong("value " + std::to_string(v) + " is out of range (at most " +
                     std::to_string(std::numeric_limits<T>::max()) + ")");
      }
      return static_cast<T>(v);
    }
    if (j.is_number_integer()) {
      const auto v = j.get<std::int64_t>();
      if (v < static_cast<std::int64_t>(std::numeric_limits<T>::min()) ||
          (std::is_signed_v<T> && v > static_cast<std::int64_t>(std::numeric_limits<T>::max()))) {
        return wrong("value " + std::to_string(v) + " is out of range [" +
                     std::to_string(std::numeric_limits<T>::min()) + ", " +
                     std::to_string(std::numeric_limits<T>::max()) + "]");
      }
      return static_cast<T>(v);
    }
    return wrong("must be an integer, got " + got());
  } else if constexpr (std::is_floating_point_v<T>) {
    // null: NaN, as the writer above writes it (an option whose NaN means "unknown").
    if (j.is_null()) return std::numeric_limits<T>::quiet_NaN();
    if (!j.is_number()) return wrong("must be a number, got " + got());
    const double v = j.get<double>();
    if (std::is_same_v<T, float> && std::isfinite(v) &&
        std::abs(v) > static_cast<double>(std::numeric_limits<float>::max())) {
      return wrong("value " + FormatNumber(v) + " is out of range for a float");
    }
    return static_cast<T>(v);
  } else if constexpr (std::is_same_v<T, std::string>) {
    if (!j.is_string()) return wrong("must be a string, got " + got());
    return j.get<std::string>();
  } else if constexpr (std::is_same_v<T, std::vector<std::string>>) {
    // A list: an array of strings, or one string (a list of one; "" = empty).
    if (j.is_string()) return j.get<std::string>().empty() ? T{} : T{j.get<std::string>()};
    if (!j.is_array()) return wrong("must be a list of strings, got " + got());
    T out;
    for (const nlohmann::json& e : j) {
      if (!e.is_string()) return wrong("must be a list of strings, got " + got());
      out.push_back(e.get<std::string>());
    }
    return out;
  } else {
    static_assert(std::is_enum_v<T>, "option field of an unsupported type");
    if (j.is_string()) {
      if (const auto e = ParseEnum<T>(j.get<std::string>())) return *e;
    }
    return wrong("must be one of " + EnumChoices<T>() + ", got " + got());
  }
}

/// `j` as a T (bool, integer, floating point, string; FromJsonValue's rules) in [lo, hi] for
/// numbers, else nullopt. For JSON written by a program that outside data may have replaced (a
/// run folder's config.json and summary.json, a simulation's sim.json) where nlohmann's get<int>()
/// would static_cast 1e300 into an int (undefined behaviour) or wrap 2^40 around.
template <class T>
std::optional<T> JsonValueIn(const nlohmann::json& j, T lo = std::numeric_limits<T>::lowest(),
                             T hi = std::numeric_limits<T>::max()) {
  try {
    const T v = FromJsonValue<T>(j, "", "");
    if constexpr (std::is_arithmetic_v<T> && !std::is_same_v<T, bool>) {
      if (!(v >= lo && v <= hi)) return std::nullopt;  // NaN (null) too
    }
    return v;
  } catch (const InvalidArgument&) {
    return std::nullopt;
  }
}

/// Writes every field as `out[key] = value`.
class JsonWriter : public GroupingVisitor<JsonWriter> {
 public:
  explicit JsonWriter(nlohmann::json* out, std::string group = "")
      : GroupingVisitor(std::move(group)), out_(out) {}
  template <class T>
  void Field(const T& value, const char* key, const char*, const Spec&) {
    (*out_)[Key(key)] = ToJsonValue(value);
  }

 private:
  nlohmann::json* out_;
};

/// `o` as one flat JSON object (keys "group.field").
template <class T>
nlohmann::json ToFlatJson(const T& o, const char* group = "") {
  nlohmann::json out = nlohmann::json::object();
  JsonWriter writer(&out, group);
  Visit(o, writer);
  return out;
}

/// Sets every field whose key (or alias, or one of the extra names `also` gives for the key, e.g.
/// a shorthand for several keys) is in a flat JSON object; fields not in it keep their value.
/// Two names of one field given with different values: InvalidArgument naming both. Records in
/// known() every name a field answers to (for the caller's unknown-key check).
class JsonReader : public GroupingVisitor<JsonReader> {
 public:
  JsonReader(const nlohmann::json& j, std::string source,
             const std::multimap<std::string, std::string>* also = nullptr, std::string group = "")
      : GroupingVisitor(std::move(group)), j_(j), source_(std::move(source)), also_(also) {}

  template <class T>
  void Field(T& value, const char* key, const char*, const Spec& spec) {
    std::vector<std::string> names{Key(key)};
    if (spec.alias) names.emplace_back(spec.alias);
    if (also_) {
      const auto range = also_->equal_range(names.front());
      for (auto it = range.first; it != range.second; ++it) names.push_back(it->second);
    }
    const std::string* first = nullptr;
    T first_value{};
    for (const std::string& n : names) {
      known_.insert(n);
      const auto it = j_.find(n);
      if (it == j_.end()) continue;
      const T v = FromJsonValue<T>(*it, n, source_);
      if (!first) {
        first = &n;
        first_value = v;
      } else if (!(v == first_value)) {
        throw InvalidArgument(source_ + ": '" + *first + "' = " + j_.at(*first).dump() + " and '" +
                              n + "' = " + it->dump() +
                              " disagree (they set the same option; give one of them)");
      }
    }
    if (first) value = first_value;
  }
  const std::set<std::string>& known() const { return known_; }

 private:
  const nlohmann::json& j_;
  std::string source_;
  const std::multimap<std::string, std::string>* also_;
  std::set<std::string> known_;
};

}  // namespace aerovo::options
