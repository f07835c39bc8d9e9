// Test helpers of the MAVLink module (not installed: testing.h is excluded; used by
// messages_test.cc and signing_test.cc): packets as hex strings, as the golden packets of
// tests/mavlink/golden.cjs are pasted, and the one packet a byte string holds.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "aerovo/mavlink/protocol.h"

namespace aerovo::mavlink::testing {

/// `b` as lower-case hex, two digits a byte.
inline std::string Hex(const std::vector<uint8_t>& b) {
  static const char* d = "0123456789abcdef";
  std::string s;
  for (uint8_t v : b) {
    s += d[v >> 4];
    s += d[v & 15];
  }
  return s;
}

/// The bytes of the hex string `hex` (two digits a byte; a trailing odd digit is ignored).
inline std::vector<uint8_t> Bytes(const std::string& hex) {
  std::vector<uint8_t> out;
  for (std::size_t i = 0; i + 1 < hex.size(); i += 2) {
    out.push_back(static_cast<uint8_t>(std::stoi(hex.substr(i, 2), nullptr, 16)));
  }
  return out;
}

/// The one packet `bytes` holds, parsed (a test failure unless the parser finds exactly one).
inline Packet ParseOne(const std::vector<uint8_t>& bytes) {
  Parser p;
  std::vector<Packet> got;
  p.Feed(bytes.data(), bytes.size(), [&](const Packet& k) { got.push_back(k); });
  EXPECT_EQ(got.size(), 1u);
  return got.empty() ? Packet{} : got.front();
}

}  // namespace aerovo::mavlink::testing
