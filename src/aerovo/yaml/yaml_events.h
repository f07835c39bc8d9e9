// libyaml's event parser (yaml_parser_parse, https://pyyaml.org/wiki/LibYAML) over a text held
// in memory, for the readers that build their own values from the events
// (camera_files/opencv_storage.cc, pipeline/run_config.cc). The parser and each event are owned
// and freed here; every error is an InputError "<where>: line <n>: <what>" with the 1-based line
// of the text.
#pragma once

#include <yaml.h>

#include <optional>
#include <string>
#include <string_view>

#include "aerovo/core/error.h"

namespace aerovo {

/// One libyaml event, owned (yaml_event_delete on destruction). `e` is libyaml's struct: its
/// type and its data (a scalar's value and style, an anchor, an alias).
struct YamlEvent {
  yaml_event_t e{};

  YamlEvent() = default;
  YamlEvent(YamlEvent&& o) noexcept : e(o.e) { o.e = yaml_event_t{}; }
  ~YamlEvent() { yaml_event_delete(&e); }
  YamlEvent(const YamlEvent&) = delete;
  YamlEvent& operator=(const YamlEvent&) = delete;
  YamlEvent& operator=(YamlEvent&&) = delete;

  /// The 1-based line of the text where the event starts.
  int line() const { return static_cast<int>(e.start_mark.line) + 1; }
  /// A scalar event's text (precondition: e.type == YAML_SCALAR_EVENT).
  std::string_view scalar() const {
    return {reinterpret_cast<const char*>(e.data.scalar.value), e.data.scalar.length};
  }
  /// A scalar written without quotes or block markers (where YAML gives it a type: numbers,
  /// booleans, null); false for "quoted", 'quoted', | and > scalars.
  bool plain() const { return e.data.scalar.style == YAML_PLAIN_SCALAR_STYLE; }
};

/// The events of one YAML text, in order. `text` must outlive the reader; `where` starts every
/// error message (a file name: "config.yaml", or "calibration 'cam.yaml'").
class YamlEvents {
 public:
  YamlEvents(std::string_view text, std::string where);
  ~YamlEvents();
  YamlEvents(const YamlEvents&) = delete;
  YamlEvents& operator=(const YamlEvents&) = delete;

  /// The next event; InputError naming the line of a syntax error (libyaml's problem).
  YamlEvent Next();

  /// The start event of the text's top-level node, which must be a mapping: InputError
  /// `not_a_mapping` at its line otherwise; nullopt when the text holds no document (empty, or
  /// only comments). After reading the mapping, call ExpectEnd.
  std::optional<YamlEvent> TopMapping(std::string_view not_a_mapping);
  /// The rest of the stream after the top-level node: InputError `second_document` at the line
  /// of a second document's node.
  void ExpectEnd(std::string_view second_document);

  /// InputError "<where>: line <line>: <what>".
  InputError Error(int line, std::string_view what) const;
  InputError Error(const YamlEvent& ev, std::string_view what) const {
    return Error(ev.line(), what);
  }
  const std::string& where() const { return where_; }

 private:
  // The next event that is not a stream or document start or a document end (the stream end
  // is returned).
  YamlEvent NextContent();

  std::string where_;
  yaml_parser_t parser_{};
};

}  // namespace aerovo
