#include "aerovo/core/text.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <system_error>

namespace aerovo {

std::optional<std::string> ReadAtMost(std::istream& in, std::size_t max_bytes) {
  std::string out;
  constexpr std::size_t kBlock = std::size_t{64} << 10;
  while (in) {
    const std::size_t at = out.size();
    const std::size_t want = std::min(kBlock, max_bytes + 1 - at);
    out.resize(at + want);
    in.read(out.data() + at, static_cast<std::streamsize>(want));
    out.resize(at + static_cast<std::size_t>(in.gcount()));
    if (out.size() > max_bytes) return std::nullopt;
  }
  return out;
}

namespace {

// The length of the UTF-8 character at s[i] (2..4), or 0 when it is not one (a stray
// continuation byte, an overlong form, a surrogate, a code point above U+10FFFF, a cut
// sequence): RFC 3629 section 4.
std::size_t Utf8Length(std::string_view s, std::size_t i) {
  const auto b = [&](std::size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned char c = b(i);
  std::size_t n = 0;
  unsigned char lo = 0x80, hi = 0xBF;  // the second byte's range
  if (c >= 0xC2 && c <= 0xDF) {
    n = 2;
  } else if (c >= 0xE0 && c <= 0xEF) {
    n = 3;
    if (c == 0xE0) lo = 0xA0;
    if (c == 0xED) hi = 0x9F;
  } else if (c >= 0xF0 && c <= 0xF4) {
    n = 4;
    if (c == 0xF0) lo = 0x90;
    if (c == 0xF4) hi = 0x8F;
  } else {
    return 0;
  }
  if (i + n > s.size() || b(i + 1) < lo || b(i + 1) > hi) return 0;
  for (std::size_t k = 2; k < n; ++k) {
    if ((b(i + k) & 0xC0) != 0x80) return 0;
  }
  return n;
}

}  // namespace

std::string_view TrimSpace(std::string_view s) {
  const auto space = [](char c) {
    return c == ' ' || c == '\t' || c == '\n' || c == '\v' || c == '\f' || c == '\r';
  };
  while (!s.empty() && space(s.front())) s.remove_prefix(1);
  while (!s.empty() && space(s.back())) s.remove_suffix(1);
  return s;
}

std::optional<double> ParseDecimal(std::string_view s) {
  s = TrimSpace(s);
  if (s.empty() || s.size() > 64) return std::nullopt;
  // The grammar is checked here, not left to from_chars: it also takes "nan", "inf" and
  // "infinity", and in C++17 a leading '+' is not taken at all.
  std::size_t i = 0;
  const bool plus = s[0] == '+';
  if (s[0] == '+' || s[0] == '-') ++i;
  std::size_t digits = 0;
  while (i < s.size() && s[i] >= '0' && s[i] <= '9') ++i, ++digits;
  if (i < s.size() && s[i] == '.') {
    ++i;
    while (i < s.size() && s[i] >= '0' && s[i] <= '9') ++i, ++digits;
  }
  if (digits == 0) return std::nullopt;
  if (i < s.size() && (s[i] == 'e' || s[i] == 'E')) {
    ++i;
    if (i < s.size() && (s[i] == '+' || s[i] == '-')) ++i;
    std::size_t exponent_digits = 0;
    while (i < s.size() && s[i] >= '0' && s[i] <= '9') ++i, ++exponent_digits;
    if (exponent_digits == 0) return std::nullopt;
  }
  if (i != s.size()) return std::nullopt;
  if (plus) s.remove_prefix(1);
  double v = 0.0;
  const std::from_chars_result r = std::from_chars(s.data(), s.data() + s.size(), v);
  if (r.ec != std::errc() || r.ptr != s.data() + s.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::string Printable(std::string_view s, std::size_t max_bytes) {
  std::string r;
  std::size_t i = 0;
  while (i < s.size() && i < max_bytes) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    if (c >= 0x20 && c < 0x7F) {
      r.push_back(static_cast<char>(c));
      ++i;
      continue;
    }
    const std::size_t n = c >= 0x80 ? Utf8Length(s, i) : 0;
    // U+0080..U+009F (C2 80..C2 9F) are the C1 controls: escaped as the C0 ones.
    if (n == 0 || i + n > max_bytes ||
        (n == 2 && c == 0xC2 && static_cast<unsigned char>(s[i + 1]) <= 0x9F)) {
      if (n != 0 && i + n > max_bytes) break;
      static const char kHex[] = "0123456789ABCDEF";
      r += "\\x";
      r.push_back(kHex[c >> 4]);
      r.push_back(kHex[c & 0xF]);
      ++i;
      continue;
    }
    r.append(s.substr(i, n));
    i += n;
  }
  if (i < s.size()) r += "...";
  return r;
}

}  // namespace aerovo
