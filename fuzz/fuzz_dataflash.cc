// libFuzzer target: ArduPilot DataFlash logs, binary and text (aerovo::ParseDataFlash, the
// parser ReadTelemetryFile uses for .bin/.log).
#include <cstddef>
#include <cstdint>

#include "aerovo/telemetry/telemetry_readers.h"
#include "fuzz_telemetry.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  aerovo::fuzz::FuzzTelemetryReader(
      data, size,
      [](std::istream& in, const std::string& name, const aerovo::TelemetryReadOptions& o) {
        return aerovo::ParseDataFlash(in, name, o);
      });
  return 0;
}
