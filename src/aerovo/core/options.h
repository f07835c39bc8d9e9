// One declarative field list per options struct, from which the run configuration's JSON/YAML
// reading and writing (core/options_json.h), the range checks of Validate(), the CLI flags
// (cli/run_cli.cc) and the option table of docs/options.md are all generated.
//
// A field list is a free function template beside the struct's Validate():
//   template <class V> void VisitFields(CorrespondenceOptions& o, V& v) {
//     v.Field(o.min_inliers, "min_inliers", "RANSAC inliers needed", options::AtLeast(1));
//     v.Group("ransac", o.ransac);  // a nested struct: its fields get the keys "ransac.*"
//   }
// A visitor provides `Field(T& member, const char* key, const char* doc, const Spec& spec)` for
// T in {bool, int, std::uint64_t, float, double, std::string, std::vector<std::string> (a list:
// a CLI flag given once per element, a JSON/YAML array or one string), an enum with EnumTraits} and
// derives from GroupingVisitor (Group sets the key prefix: "match" -> "match.max_ratio"; a
// group's name is absolute, not appended to the parent's, so every key is "group.field").
// Not a hot path: visitors allocate freely.
#pragma once

#include <array>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include "aerovo/core/error.h"

namespace aerovo::options {

/// What a field accepts beyond its type (a numeric range, finiteness) and how it is also known
/// (a short legacy key/flag, extra CLI names). Built with the helpers below, e.g.
/// `options::GreaterThan(0.0).Finite()`, `options::AtLeast(0).Alias("max_keypoints")`.
struct Spec {
  bool has_min = false, min_open = false, has_max = false, max_open = false;
  double min = 0.0, max = 0.0;
  bool finite = false;          ///< NaN and +-inf rejected.
  const char* alias = nullptr;  ///< Legacy flat key, also a CLI flag (--mode, --surf-threshold).
  const char* extra_flags = nullptr;  ///< More CLI names, comma separated ("-o", "--altitude").
  bool cli_switch = false;  ///< CLI flag without a value (--quiet); else the flag takes a value.

  constexpr Spec Finite() const {
    Spec s = *this;
    s.finite = true;
    return s;
  }
  constexpr Spec Alias(const char* name) const {
    Spec s = *this;
    s.alias = name;
    return s;
  }
  constexpr Spec Flags(const char* names) const {
    Spec s = *this;
    s.extra_flags = names;
    return s;
  }
  constexpr Spec Switch() const {
    Spec s = *this;
    s.cli_switch = true;
    return s;
  }
  bool HasRange() const { return has_min || has_max || finite; }
  /// True when `v` satisfies the range (NaN fails any bound).
  bool Contains(double v) const {
    if (finite && !std::isfinite(v)) return false;
    if (has_min && !(min_open ? v > min : v >= min)) return false;
    if (has_max && !(max_open ? v < max : v <= max)) return false;
    return true;
  }
  /// "> 0", ">= 1", "in (0, 1]", "finite", "finite and > 0"; "" without a range.
  std::string Describe() const;
};

inline constexpr Spec Any() { return Spec{}; }
inline constexpr Spec Finite() { return Spec{}.Finite(); }
inline constexpr Spec AtLeast(double lo) {
  Spec s;
  s.has_min = true;
  s.min = lo;
  return s;
}
inline constexpr Spec GreaterThan(double lo) {
  Spec s = AtLeast(lo);
  s.min_open = true;
  return s;
}
inline constexpr Spec AtMost(double hi) {
  Spec s;
  s.has_max = true;
  s.max = hi;
  return s;
}
/// lo <= v <= hi, or with open ends: Interval(0, 1, true, false) is (0, 1].
inline constexpr Spec Interval(double lo, double hi, bool lo_open = false, bool hi_open = false) {
  Spec s = AtLeast(lo);
  s.min_open = lo_open;
  s.has_max = true;
  s.max = hi;
  s.max_open = hi_open;
  return s;
}

/// The upper bound of a thread-count option (SURF's, matching's; 0 = one per core): a loop
/// (core/parallel.h) keeps that many threads, each with its scratch buffers; under OpenMP,
/// 100000 of them crashed `aerovo run` (threads that could not be created: a segmentation
/// fault, exit 139) or exhausted memory. 256 is 2 per hardware thread of a two-socket server.
inline constexpr int kMaxOptionThreads = 256;

/// Shortest text that reads back as the same value ("1.5", "-1", "1e+300", "nan").
template <class T>
std::string FormatNumber(T v) {
  if constexpr (std::is_floating_point_v<T>) {
    if (std::isnan(v)) return "nan";
    if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  }
  std::array<char, 64> buf{};
  const auto r = std::to_chars(buf.data(), buf.data() + buf.size(), v);
  return std::string(buf.data(), r.ptr);
}

/// A range's bound as a reader writes it: a whole number below 1e15 in plain digits ("100000",
/// "-1000000", where FormatNumber gives "1e+05"), any other value as FormatNumber.
inline std::string FormatBound(double v) {
  if (std::isfinite(v) && v == std::trunc(v) && std::fabs(v) < 1e15) {
    return std::to_string(static_cast<long long>(v));
  }
  return FormatNumber(v);
}

inline std::string Spec::Describe() const {
  std::string range;
  if (has_min && has_max) {
    range = std::string("in ") + (min_open ? "(" : "[") + FormatBound(min) + ", " +
            FormatBound(max) + (max_open ? ")" : "]");
  } else if (has_min) {
    range = std::string(min_open ? "> " : ">= ") + FormatBound(min);
  } else if (has_max) {
    range = std::string(max_open ? "< " : "<= ") + FormatBound(max);
  }
  if (!finite) return range;
  return range.empty() ? "finite" : "finite and " + range;
}

/// The names of an enum's values. Specialise beside the field list that uses the enum:
///   template <> struct EnumTraits<MotionModel>
///       : EnumList<MotionModel, ToString, MotionModel::kTranslation, ...> {};
/// (names from the enum's existing ToString); an enum without one gets the two members
/// directly: `static constexpr E kValues[]` and `static const char* Name(E)`.
template <class E>
struct EnumTraits;

template <class E, const char* (*ToName)(E), E... Values>
struct EnumList {
  static constexpr E kValues[] = {Values...};
  static const char* Name(E e) { return ToName(e); }
};

template <class E>
const char* EnumName(E e) {
  return EnumTraits<E>::Name(e);
}
/// Every name, in the order of kValues.
template <class E>
std::vector<std::string> EnumNames() {
  std::vector<std::string> out;
  for (const E e : EnumTraits<E>::kValues) out.emplace_back(EnumTraits<E>::Name(e));
  return out;
}
/// "a | b | c".
template <class E>
std::string EnumChoices() {
  std::string out;
  for (const std::string& n : EnumNames<E>()) out += (out.empty() ? "" : " | ") + n;
  return out;
}
template <class E>
std::optional<E> ParseEnum(const std::string& name) {
  for (const E e : EnumTraits<E>::kValues) {
    if (name == EnumTraits<E>::Name(e)) return e;
  }
  return std::nullopt;
}

/// "bool", "int", "uint64", "float", "double", "string", "enum".
template <class T>
const char* TypeName() {
  if constexpr (std::is_same_v<T, bool>) {
    return "bool";
  } else if constexpr (std::is_same_v<T, int>) {
    return "int";
  } else if constexpr (std::is_same_v<T, std::uint64_t>) {
    return "uint64";
  } else if constexpr (std::is_same_v<T, float>) {
    return "float";
  } else if constexpr (std::is_same_v<T, double>) {
    return "double";
  } else if constexpr (std::is_same_v<T, std::string>) {
    return "string";
  } else if constexpr (std::is_same_v<T, std::vector<std::string>>) {
    return "strings";
  } else {
    static_assert(std::is_enum_v<T>, "option field of an unsupported type");
    return "enum";
  }
}

/// Base of every visitor: the key prefix of the group being visited. `Derived` must be the
/// visitor (CRTP), so that Group() calls VisitFields(child, derived) found by ADL.
template <class Derived>
class GroupingVisitor {
 public:
  /// Visits `child`'s fields with the keys "name.<field>"; name "" = no prefix.
  template <class T>
  void Group(const char* name, T& child) {
    if (!recurse_) return;
    const std::string saved = prefix_;
    prefix_ = *name ? std::string(name) + "." : std::string();
    VisitFields(child, static_cast<Derived&>(*this));
    prefix_ = saved;
  }
  /// The full key of a field of the group being visited.
  std::string Key(const char* field) const { return prefix_ + field; }
  const std::string& prefix() const { return prefix_; }

 protected:
  explicit GroupingVisitor(std::string prefix = "", bool recurse = true)
      : prefix_(prefix.empty() ? prefix : prefix + "."), recurse_(recurse) {}

 private:
  std::string prefix_;
  bool recurse_;
};

/// Calls the field list of `o` (const visitors only read; the list takes a non-const reference
/// so that one list serves readers and writers).
template <class T, class V>
void Visit(const T& o, V& v) {
  VisitFields(const_cast<T&>(o), v);
}

/// The range check of every field, in the one message style
/// "<key> must be > 0, got -1" (InvalidArgument, `context` + ": " before it when not empty).
class RangeChecker : public GroupingVisitor<RangeChecker> {
 public:
  /// `group`: the key prefix of the struct's own fields; `recurse`: also nested groups.
  RangeChecker(std::string group, bool recurse, std::string context = "")
      : GroupingVisitor(std::move(group), recurse), context_(std::move(context)) {}

  template <class T>
  void Field(const T& value, const char* key, const char*, const Spec& spec) {
    if constexpr (std::is_arithmetic_v<T> && !std::is_same_v<T, bool>) {
      if (!spec.HasRange() || spec.Contains(static_cast<double>(value))) return;
      Fail(Key(key) + " must be " + spec.Describe() + ", got " + FormatNumber(value));
    } else if constexpr (std::is_enum_v<T>) {
      for (const T e : EnumTraits<T>::kValues) {
        if (e == value) return;
      }
      Fail(Key(key) + " must be one of " + EnumChoices<T>() + ", got value " +
           std::to_string(static_cast<long long>(value)));
    }
  }
  /// A rule ranges cannot express, in the same style: "<key> <what>".
  void Fail(const std::string& message) const {
    throw InvalidArgument(context_.empty() ? message : context_ + ": " + message);
  }

 private:
  std::string context_;
};

/// Range checks of `o`'s fields (keys "group.field"); nested groups too when `recurse`.
template <class T>
void CheckRanges(const T& o, const char* group, bool recurse = false,
                 const std::string& context = "") {
  RangeChecker checker(group, recurse, context);
  Visit(o, checker);
}

/// One row per field, for tables and help (the lister below; tests iterate it).
struct FieldInfo {
  std::string key;
  std::string alias;
  std::string type;   ///< TypeName, or "a | b | c" for an enum.
  std::string value;  ///< The value in the visited struct (the default for a default one).
  std::string range;  ///< Spec::Describe().
  std::string doc;
  bool cli_switch = false;
  std::string extra_flags;
};

class FieldLister : public GroupingVisitor<FieldLister> {
 public:
  explicit FieldLister(std::string group = "") : GroupingVisitor(std::move(group)) {}
  template <class T>
  void Field(const T& value, const char* key, const char* doc, const Spec& spec) {
    FieldInfo f;
    f.key = Key(key);
    f.alias = spec.alias ? spec.alias : "";
    f.doc = doc;
    f.range = spec.Describe();
    f.cli_switch = spec.cli_switch;
    f.extra_flags = spec.extra_flags ? spec.extra_flags : "";
    if constexpr (std::is_enum_v<T>) {
      f.type = EnumChoices<T>();
      f.value = EnumName(value);
    } else if constexpr (std::is_same_v<T, bool>) {
      f.type = "bool";
      f.value = value ? "true" : "false";
    } else if constexpr (std::is_same_v<T, std::string>) {
      f.type = "string";
      f.value = "\"" + value + "\"";
    } else if constexpr (std::is_same_v<T, std::vector<std::string>>) {
      f.type = TypeName<T>();
      for (const std::string& e : value) f.value += (f.value.empty() ? "\"" : ", \"") + e + "\"";
      f.value = "[" + f.value + "]";
    } else {
      f.type = TypeName<T>();
      f.value = FormatNumber(value);
    }
    fields.push_back(std::move(f));
  }
  std::vector<FieldInfo> fields;
};

template <class T>
std::vector<FieldInfo> ListFields(const T& o, const char* group = "") {
  FieldLister lister(group);
  Visit(o, lister);
  return lister.fields;
}

/// "ransac.max_distance_px" -> "--ransac-max-distance-px".
inline std::string FlagName(const std::string& key) {
  std::string out = "--";
  for (const char c : key) out += (c == '.' || c == '_') ? '-' : c;
  return out;
}

/// The negation of a boolean flag: "--guided" -> "--no-guided" (every boolean option of the CLI
/// is a switch: `--X` sets it, `--no-X` clears it, `--X=false` also works).
inline std::string NegatedFlagName(const std::string& flag) { return "--no-" + flag.substr(2); }

/// A Markdown table of `fields`: key (and legacy alias), flag, type, default, range, doc.
/// Boolean options list their negations (`--no-X`) as well.
inline std::string MarkdownTable(const std::vector<FieldInfo>& fields) {
  const auto cell = [](std::string s) {
    std::string out;
    for (const char c : s) out += c == '|' ? std::string("\\|") : std::string(1, c);
    return out;
  };
  std::ostringstream md;
  md << "| Key | Flag | Type | Default | Range | Description |\n";
  md << "|---|---|---|---|---|---|\n";
  for (const FieldInfo& f : fields) {
    std::string key = "`" + f.key + "`";
    const bool boolean = f.type == "bool";
    std::string flag = "`" + FlagName(f.key) + "`";
    if (boolean) flag += "/`" + NegatedFlagName(FlagName(f.key)) + "`";
    std::string extra = f.extra_flags;  // "-o", "--altitude", "input" (positional)
    while (!extra.empty()) {
      const std::string name = extra.substr(0, extra.find(','));
      extra = name.size() < extra.size() ? extra.substr(name.size() + 1) : std::string();
      flag += name[0] == '-' ? ", `" + name + "`" : " (positional)";
    }
    if (!f.alias.empty()) {
      key += " (`" + f.alias + "`)";
      flag += ", `" + FlagName(f.alias) + "`";
      if (boolean) flag += "/`" + NegatedFlagName(FlagName(f.alias)) + "`";
    }
    md << "| " << key << " | " << flag << " | " << cell(f.type) << " | `" << f.value << "` | "
       << f.range << " | " << cell(f.doc) << " |\n";
  }
  return md.str();
}

}  // namespace aerovo::options
