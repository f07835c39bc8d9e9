// libFuzzer target: MAVLink telemetry logs (aerovo::ParseTlog, the parser ReadTelemetryFile uses
// for .tlog).
#include <cstddef>
#include <cstdint>

#include "aerovo/telemetry/telemetry_readers.h"
#include "fuzz_telemetry.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  aerovo::fuzz::FuzzTelemetryReader(
      data, size,
      [](std::istream& in, const std::string& name, const aerovo::TelemetryReadOptions& o) {
        return aerovo::ParseTlog(in, name, o);
      });
  return 0;
}
