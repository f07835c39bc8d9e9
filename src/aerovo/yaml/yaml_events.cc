#include "aerovo/yaml/yaml_events.h"

#include <utility>

#include <fmt/format.h>

namespace aerovo {

YamlEvents::YamlEvents(std::string_view text, std::string where) : where_(std::move(where)) {
  if (!yaml_parser_initialize(&parser_)) {
    throw InputError(where_ + ": cannot initialise libyaml");
  }
  yaml_parser_set_input_string(&parser_, reinterpret_cast<const unsigned char*>(text.data()),
                               text.size());
}

YamlEvents::~YamlEvents() { yaml_parser_delete(&parser_); }

YamlEvent YamlEvents::Next() {
  YamlEvent ev;
  if (!yaml_parser_parse(&parser_, &ev.e)) {
    throw Error(static_cast<int>(parser_.problem_mark.line) + 1,
                parser_.problem != nullptr ? parser_.problem : "YAML syntax error");
  }
  return ev;
}

YamlEvent YamlEvents::NextContent() {
  for (;;) {
    YamlEvent ev = Next();
    const yaml_event_type_t type = ev.e.type;
    if (type != YAML_STREAM_START_EVENT && type != YAML_DOCUMENT_START_EVENT &&
        type != YAML_DOCUMENT_END_EVENT) {
      return ev;
    }
  }
}

std::optional<YamlEvent> YamlEvents::TopMapping(std::string_view not_a_mapping) {
  YamlEvent ev = NextContent();
  if (ev.e.type == YAML_STREAM_END_EVENT) return std::nullopt;
  if (ev.e.type != YAML_MAPPING_START_EVENT) throw Error(ev, not_a_mapping);
  return ev;
}

void YamlEvents::ExpectEnd(std::string_view second_document) {
  const YamlEvent ev = NextContent();
  if (ev.e.type != YAML_STREAM_END_EVENT) throw Error(ev, second_document);
}

InputError YamlEvents::Error(int line, std::string_view what) const {
  return InputError(fmt::format("{}: line {}: {}", where_, line, what));
}

}  // namespace aerovo
