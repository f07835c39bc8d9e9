// A small builder of HTML text for the report pages (report/html_report.cc): the one place
// where text and attribute values are escaped (XmlEscape, core/text.h: & < > " '), so that a
// file name, a run label or a caption cannot break the page's markup.
//
//   HtmlBuilder h;
//   h.Open("p", {{"class", "meta"}}).Text("Run folder ").Element("code", {}, dir).Close("p");
//   // <p class="meta">Run folder <code>DIR, escaped</code></p>
//
// Raw() appends markup that is already HTML (an inline SVG, a script, a fragment built by
// another HtmlBuilder): the only way to add unescaped text, and meant for trusted markup only.
#pragma once

#include <cstddef>
#include <initializer_list>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "aerovo/core/text.h"

namespace aerovo {

/// One attribute: name (trusted: a literal of the code) and value (escaped).
using HtmlAttribute = std::pair<std::string_view, std::string_view>;

class HtmlBuilder {
 public:
  using Attributes = std::vector<HtmlAttribute>;

  /// `<tag name="value" ...>`, the values escaped, in the given order.
  HtmlBuilder& Open(std::string_view tag, const Attributes& attributes = {}) {
    html_ += '<';
    html_ += tag;
    for (const auto& [name, value] : attributes) {
      html_ += ' ';
      html_ += name;
      html_ += "=\"";
      html_ += XmlEscape(value);
      html_ += '"';
    }
    html_ += '>';
    return *this;
  }
  /// `</tag>`.
  HtmlBuilder& Close(std::string_view tag) {
    html_ += "</";
    html_ += tag;
    html_ += '>';
    return *this;
  }
  /// `<tag attributes>text</tag>`, the text escaped.
  HtmlBuilder& Element(std::string_view tag, const Attributes& attributes, std::string_view text) {
    return Open(tag, attributes).Text(text).Close(tag);
  }
  /// `text`, escaped.
  HtmlBuilder& Text(std::string_view text) {
    html_ += XmlEscape(text);
    return *this;
  }
  /// `html` as is: markup already built (see the file comment).
  HtmlBuilder& Raw(std::string_view html) {
    html_ += html;
    return *this;
  }
  /// A line break of the HTML source ('\n').
  HtmlBuilder& Newline() {
    html_ += '\n';
    return *this;
  }
  /// Inserts `other`'s markup at byte offset `at` (a size() taken earlier): a section built
  /// after the ones that follow it on the page.
  HtmlBuilder& Insert(std::size_t at, const HtmlBuilder& other) {
    html_.insert(at, other.html_);
    return *this;
  }

  const std::string& str() const { return html_; }
  std::size_t size() const { return html_.size(); }

 private:
  std::string html_;
};

}  // namespace aerovo
