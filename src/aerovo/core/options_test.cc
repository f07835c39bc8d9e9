#include "aerovo/core/options.h"

#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <string>

#include <gtest/gtest.h>

#include "aerovo/core/error.h"
#include "aerovo/core/options_json.h"

namespace aerovo {
namespace {

enum class Colour { kRed, kDeepBlue };
const char* ToString(Colour c) { return c == Colour::kRed ? "red" : "deep-blue"; }

struct Inner {
  float ratio = 0.6f;
  std::uint64_t seed = 1;
};
struct Outer {
  int count = 3;
  double scale = 1.5;
  bool on = true;
  std::string name = "x";
  Colour colour = Colour::kRed;
  Inner inner;
};

template <class V>
void VisitFields(Inner& o, V& v) {
  using namespace options;
  v.Field(o.ratio, "ratio", "A ratio", Interval(0, 1, true, false));
  v.Field(o.seed, "seed", "A seed", Any().Alias("seed"));
}
template <class V>
void VisitFields(Outer& o, V& v) {
  using namespace options;
  v.Field(o.count, "count", "A count", AtLeast(1).Alias("n"));
  v.Field(o.scale, "scale", "A scale", GreaterThan(0).Finite());
  v.Field(o.on, "on", "A switch", Any());
  v.Field(o.name, "name", "A name", Any());
  v.Field(o.colour, "colour", "A colour", Any());
  v.Group("inner", o.inner);
}

}  // namespace

template <>
struct options::EnumTraits<Colour>
    : options::EnumList<Colour, ToString, Colour::kRed, Colour::kDeepBlue> {};

namespace {

std::string InvalidMessage(const std::function<void()>& f) {
  try {
    f();
  } catch (const InvalidArgument& e) {
    return e.what();
  }
  return "(no InvalidArgument)";
}

TEST(Options, SpecDescribesAndContains) {
  EXPECT_EQ(options::GreaterThan(0).Describe(), "> 0");
  EXPECT_EQ(options::AtLeast(1).Describe(), ">= 1");
  EXPECT_EQ(options::AtMost(2.5).Describe(), "<= 2.5");
  EXPECT_EQ(options::Interval(0, 1, true, false).Describe(), "in (0, 1]");
  EXPECT_EQ(options::Interval(0, 180, false, true).Describe(), "in [0, 180)");
  EXPECT_EQ(options::Finite().Describe(), "finite");
  EXPECT_EQ(options::GreaterThan(0).Finite().Describe(), "finite and > 0");
  EXPECT_EQ(options::Any().Describe(), "");
  // Whole bounds in plain digits, as docs/options.md and the messages quote them.
  EXPECT_EQ(options::Interval(0, 1e5).Describe(), "in [0, 100000]");
  EXPECT_EQ(options::Interval(-1e6, 1e6).Describe(), "in [-1000000, 1000000]");
  EXPECT_EQ(options::AtMost(1e300).Describe(), "<= 1e+300");
  EXPECT_EQ(options::AtLeast(-0.25).Describe(), ">= -0.25");
  EXPECT_TRUE(options::Interval(0, 1, true, false).Contains(1.0));
  EXPECT_FALSE(options::Interval(0, 1, true, false).Contains(0.0));
  EXPECT_FALSE(options::AtLeast(0).Contains(std::nan("")));
  EXPECT_TRUE(options::AtLeast(0).Contains(HUGE_VAL));
  EXPECT_FALSE(options::AtLeast(0).Finite().Contains(HUGE_VAL));
  EXPECT_EQ(options::FormatNumber(0.6f), "0.6");
  EXPECT_EQ(options::FormatNumber(-1), "-1");
  EXPECT_EQ(options::FormatNumber(1.5), "1.5");
  EXPECT_EQ(options::FlagName("ransac.max_distance_px"), "--ransac-max-distance-px");
}

TEST(Options, EnumNamesComeFromToString) {
  EXPECT_EQ(options::EnumNames<Colour>(), (std::vector<std::string>{"red", "deep-blue"}));
  EXPECT_EQ(options::ParseEnum<Colour>("deep-blue"), Colour::kDeepBlue);
  EXPECT_FALSE(options::ParseEnum<Colour>("green").has_value());
  EXPECT_EQ(options::EnumChoices<Colour>(), "red | deep-blue");
}

TEST(Options, RangeCheckerOneMessageStyle) {
  Outer o;
  EXPECT_NO_THROW(options::CheckRanges(o, "outer", true));
  o.inner.ratio = 2.f;
  EXPECT_EQ(InvalidMessage([&] { options::CheckRanges(o, "outer", true); }),
            "inner.ratio must be in (0, 1], got 2");
  // Not recursing: the nested group is someone else's Validate.
  EXPECT_NO_THROW(options::CheckRanges(o, "outer", false));
  o.inner.ratio = 0.5f;
  o.scale = -1.0;
  EXPECT_EQ(InvalidMessage([&] { options::CheckRanges(o, "outer", false, "cfg"); }),
            "cfg: outer.scale must be finite and > 0, got -1");
  o.scale = HUGE_VAL;
  EXPECT_EQ(InvalidMessage([&] { options::CheckRanges(o, "", false); }),
            "scale must be finite and > 0, got inf");
  o.scale = 1.0;
  o.count = 0;
  EXPECT_EQ(InvalidMessage([&] { options::CheckRanges(o, "outer"); }),
            "outer.count must be >= 1, got 0");
  o.count = 1;
  o.colour = static_cast<Colour>(7);
  EXPECT_NE(InvalidMessage([&] {
              options::CheckRanges(o, "outer");
            }).find("outer.colour must be one of red | deep-blue"),
            std::string::npos);
}

TEST(Options, JsonWriterAndReaderRoundTrip) {
  Outer o;
  o.count = 7;
  o.scale = 0.1;
  o.on = false;
  o.name = "y";
  o.colour = Colour::kDeepBlue;
  o.inner.ratio = 0.3f;
  o.inner.seed = 18446744073709551615ull;
  const nlohmann::json j = options::ToFlatJson(o);
  EXPECT_EQ(j, (nlohmann::json{{"count", 7},
                               {"scale", 0.1},
                               {"on", false},
                               {"name", "y"},
                               {"colour", "deep-blue"},
                               {"inner.ratio", 0.3},  // the float's shortest decimal
                               {"inner.seed", 18446744073709551615ull}}));
  Outer back;
  options::JsonReader reader(j, "t.json");
  VisitFields(back, reader);
  EXPECT_EQ(options::ToFlatJson(back), j);
  EXPECT_EQ(back.inner.ratio, 0.3f);
  EXPECT_EQ(reader.known().count("n"), 1u);  // the alias is a known name
  EXPECT_EQ(reader.known().count("inner.seed"), 1u);
}

Outer Read(const nlohmann::json& j, const std::multimap<std::string, std::string>* also = nullptr) {
  Outer o;
  options::JsonReader reader(j, "t.json", also);
  VisitFields(o, reader);
  return o;
}

TEST(Options, JsonReaderTypeAndRangeErrorsNameTheKey) {
  const auto message = [](const nlohmann::json& j) { return InvalidMessage([&] { Read(j); }); };
  EXPECT_EQ(message({{"count", "two"}}),
            "t.json: key 'count' must be an integer, got string \"two\"");
  EXPECT_EQ(message({{"count", 2.5}}), "t.json: key 'count' must be an integer, got number 2.5");
  EXPECT_EQ(message({{"count", 4294967297ll}}),
            "t.json: key 'count' value 4294967297 is out of range [-2147483648, 2147483647]");
  EXPECT_EQ(message({{"n", 3000000000ull}}),
            "t.json: key 'n' value 3000000000 is out of range (at most 2147483647)");
  EXPECT_EQ(message({{"inner.seed", -1}}),
            "t.json: key 'inner.seed' value -1 is out of range [0, 18446744073709551615]");
  EXPECT_EQ(message({{"on", 1}}),
            "t.json: key 'on' must be a boolean (true or false), got number 1");
  EXPECT_EQ(message({{"scale", "big"}}),
            "t.json: key 'scale' must be a number, got string \"big\"");
  EXPECT_EQ(message({{"name", 3}}), "t.json: key 'name' must be a string, got number 3");
  EXPECT_EQ(message({{"colour", "green"}}),
            "t.json: key 'colour' must be one of red | deep-blue, got string \"green\"");
  EXPECT_EQ(message({{"inner.ratio", 1e300}}),
            "t.json: key 'inner.ratio' value 1e+300 is out of range for a float");
}

// JsonValueIn: a value of JSON that outside data may have replaced, read without a cast that
// could be undefined (nlohmann's get<int>() of 1e300) or wrap (2^40 into an int).
TEST(Options, JsonValueInChecksTypeAndRangeBeforeAnyCast) {
  using options::JsonValueIn;
  EXPECT_EQ(JsonValueIn<int>(nlohmann::json(42)), 42);
  EXPECT_EQ(JsonValueIn<int>(nlohmann::json(42), 1, 100), 42);
  EXPECT_FALSE(JsonValueIn<int>(nlohmann::json(420), 1, 100));
  EXPECT_FALSE(JsonValueIn<int>(nlohmann::json(1e300)));
  EXPECT_FALSE(JsonValueIn<int>(nlohmann::json(2.5)));
  EXPECT_FALSE(JsonValueIn<int>(nlohmann::json(1LL << 40)));
  EXPECT_FALSE(JsonValueIn<int>(nlohmann::json("12")));
  EXPECT_FALSE(JsonValueIn<int>(nlohmann::json(nullptr)));
  EXPECT_FALSE(JsonValueIn<std::uint64_t>(nlohmann::json(-1)));
  EXPECT_EQ(JsonValueIn<std::uint64_t>(nlohmann::json(18446744073709551615ULL)),
            18446744073709551615ULL);
  EXPECT_EQ(JsonValueIn<double>(nlohmann::json(3)), 3.0);
  EXPECT_FALSE(JsonValueIn<double>(nlohmann::json(nullptr)));  // FromJsonValue's NaN
  EXPECT_FALSE(JsonValueIn<double>(nlohmann::json(5.0), 0.0, 1.0));
  EXPECT_EQ(JsonValueIn<std::string>(nlohmann::json("auto")), "auto");
  EXPECT_FALSE(JsonValueIn<std::string>(nlohmann::json(3)));
}

TEST(Options, AliasesAndExtraNamesSetTheFieldAndConflictsNameBoth) {
  EXPECT_EQ(Read({{"n", 5}}).count, 5);
  EXPECT_EQ(Read({{"n", 5}, {"count", 5}}).count, 5);  // same value: fine
  EXPECT_EQ(
      InvalidMessage([] {
        Read({{"n", 5}, {"count", 6}});
      }),
      "t.json: 'count' = 6 and 'n' = 5 disagree (they set the same option; give one of them)");
  const std::multimap<std::string, std::string> also{{"count", "both"}, {"inner.seed", "both"}};
  const Outer o = Read({{"both", 9}}, &also);
  EXPECT_EQ(o.count, 9);
  EXPECT_EQ(o.inner.seed, 9u);
  const std::string m = InvalidMessage([&] { Read({{"both", 9}, {"inner.seed", 2}}, &also); });
  EXPECT_NE(m.find("'inner.seed' = 2 and 'both' = 9 disagree"), std::string::npos) << m;
}

TEST(Options, ListerAndMarkdownTable) {
  const std::vector<options::FieldInfo> fields = options::ListFields(Outer{});
  ASSERT_EQ(fields.size(), 7u);
  EXPECT_EQ(fields[0].key, "count");
  EXPECT_EQ(fields[0].alias, "n");
  EXPECT_EQ(fields[0].value, "3");
  EXPECT_EQ(fields[4].type, "red | deep-blue");
  EXPECT_EQ(fields[5].key, "inner.ratio");
  EXPECT_EQ(fields[5].value, "0.6");
  const std::string md = options::MarkdownTable(fields);
  EXPECT_NE(md.find("| `count` (`n`) | `--count`, `--n` | int | `3` | >= 1 | A count |"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("| `colour` | `--colour` | red \\| deep-blue | `red` |  | A colour |"),
            std::string::npos)
      << md;
}

}  // namespace
}  // namespace aerovo
