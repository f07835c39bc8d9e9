// YamlEvents (yaml_events.h): the events of a text in order, the one top-level mapping, and
// errors that name the line.
#include "aerovo/yaml/yaml_events.h"

#include <gtest/gtest.h>

#include <optional>
#include <string>
#include <vector>

namespace aerovo::yaml_events_test {
namespace {

std::string ErrorOf(const std::string& text, void (*read)(YamlEvents&)) {
  try {
    YamlEvents events(text, "cfg.yaml");
    read(events);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(YamlEvents, EventsOfAMappingInOrderWithLinesAndScalars) {
  const std::string text = "a: 1\nb: 'two'\nc: [x, y]\n";
  YamlEvents events(text, "cfg.yaml");
  std::optional<YamlEvent> top = events.TopMapping("not a mapping");
  ASSERT_TRUE(top.has_value());
  EXPECT_EQ(top->line(), 1);
  struct Seen {
    yaml_event_type_t type;
    std::string text;
    bool plain;
    int line;
  };
  std::vector<Seen> seen;
  for (;;) {
    const YamlEvent ev = events.Next();
    if (ev.e.type == YAML_MAPPING_END_EVENT) break;
    const bool scalar = ev.e.type == YAML_SCALAR_EVENT;
    seen.push_back({ev.e.type, scalar ? std::string(ev.scalar()) : std::string(),
                    scalar && ev.plain(), ev.line()});
  }
  events.ExpectEnd("second document");
  ASSERT_EQ(seen.size(), 9u);  // a 1 b two c [ x y ]
  EXPECT_EQ(seen[0].text, "a");
  EXPECT_EQ(seen[1].text, "1");
  EXPECT_TRUE(seen[1].plain);
  EXPECT_EQ(seen[3].text, "two");
  EXPECT_FALSE(seen[3].plain);  // quoted: a string, whatever it holds
  EXPECT_EQ(seen[3].line, 2);
  EXPECT_EQ(seen[5].type, YAML_SEQUENCE_START_EVENT);
  EXPECT_EQ(seen[6].text, "x");
  EXPECT_EQ(seen[6].line, 3);
  EXPECT_EQ(seen[7].text, "y");
  EXPECT_EQ(seen[8].type, YAML_SEQUENCE_END_EVENT);
}

TEST(YamlEvents, AnEmptyTextOrOnlyCommentsHasNoTopMapping) {
  for (const std::string text : {"", "# nothing\n", "\n\n# nothing\n"}) {
    SCOPED_TRACE(text);
    YamlEvents events(text, "cfg.yaml");
    EXPECT_FALSE(events.TopMapping("not a mapping").has_value());
  }
  // An explicit document without content holds a null node, which is not a mapping.
  YamlEvents events("---\n...\n", "cfg.yaml");
  EXPECT_THROW((void)events.TopMapping("not a mapping"), InputError);
}

TEST(YamlEvents, ErrorsNameTheWhereAndTheLine) {
  // Not a mapping at the top: the caller's words, at the node's line.
  EXPECT_EQ(ErrorOf("# a comment\n- 1\n- 2\n",
                    [](YamlEvents& e) { (void)e.TopMapping("must be a mapping"); }),
            "cfg.yaml: line 2: must be a mapping");
  // A second document after the first one's mapping.
  EXPECT_EQ(ErrorOf("a: 1\n---\nb: 2\n",
                    [](YamlEvents& e) {
                      (void)e.TopMapping("must be a mapping");
                      while (e.Next().e.type != YAML_MAPPING_END_EVENT) {
                      }
                      e.ExpectEnd("one document only");
                    }),
            "cfg.yaml: line 3: one document only");
  // A syntax error: libyaml's problem at its line.
  const std::string syntax = ErrorOf("a: 1\nb: [1, 2\nc: 3\n", [](YamlEvents& e) {
    for (;;) {
      if (e.Next().e.type == YAML_STREAM_END_EVENT) break;
    }
  });
  EXPECT_EQ(syntax.rfind("cfg.yaml: line 3: ", 0), 0u) << syntax;
  // The caller's own error at an event's line.
  EXPECT_EQ(ErrorOf("a: 1\nb: 2\n",
                    [](YamlEvents& e) {
                      (void)e.TopMapping("must be a mapping");
                      (void)e.Next();
                      (void)e.Next();
                      const YamlEvent b = e.Next();
                      throw e.Error(b, "key b is not known");
                    }),
            "cfg.yaml: line 2: key b is not known");
}

}  // namespace
}  // namespace aerovo::yaml_events_test
