// Small text helpers shared by the writers of XML-family outputs (KML, GPX, HTML, SVG).
#pragma once

#include <string>
#include <string_view>

namespace aerovo {

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
