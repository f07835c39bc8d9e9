// Small text helpers: the one strict reader of numbers in outside text (telemetry, calibration
// files, run folders, command-line lists), and escaping for the writers of XML-family outputs
// (KML, GPX, HTML, SVG).
#pragma once

#include <cstddef>
#include <istream>
#include <optional>
#include <string>
#include <string_view>

namespace aerovo {

/// The rest of `in`, when it holds at most `max_bytes` bytes; nullopt when it holds more: a file
/// far larger than what it is given as, or one that never ends (/dev/zero, a pipe fed forever),
/// which a read to the end would hold in memory until none is left. At most max_bytes + 1 bytes
/// are read (in 64 KiB blocks).
std::optional<std::string> ReadAtMost(std::istream& in, std::size_t max_bytes);

/// `s` without its leading and trailing ASCII white space (space, \t, \n, \v, \f, \r; never
/// locale-dependent).
std::string_view TrimSpace(std::string_view s);

/// The number `s` spells, white space around it allowed: an optional sign ('+' or '-'), decimal
/// digits with at most one '.', and an optional exponent ('e' or 'E', optional sign, digits);
/// finite, and not so small that it rounds to 0 (below 4.9e-324; "0e999" is 0). nullopt for
/// anything else: "nan", "inf", hexadecimal, "1e400", "1.5m", "1,5", "", more than 64
/// characters. The decimal point is '.' whatever the C locale (std::from_chars is
/// locale-independent, C++17 [utility.from.chars]), so a host program's setlocale (Python's
/// locale module) does not change what a file means; strtod and std::stod accept all of the
/// above and follow the locale.
std::optional<double> ParseDecimal(std::string_view s);

/// `s` as it may be quoted in a message: at most `max_bytes` bytes of it (cut at a character,
/// "..." appended), its control characters (C0, DEL, C1: a terminal would act on ESC sequences)
/// and bytes that are not UTF-8 written as "\xNN". Input text is never printed raw.
std::string Printable(std::string_view s, std::size_t max_bytes = 60);

/// `text` with the five XML special characters replaced by entities (&amp; &lt; &gt; &quot;
/// &apos;), safe in XML/HTML element content and in quoted attribute values. &apos; is valid in
/// XML 1.0 and HTML5.
inline std::string XmlEscape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

}  // namespace aerovo
