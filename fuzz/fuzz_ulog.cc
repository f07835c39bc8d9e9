// libFuzzer target: PX4 ULog flight logs (aerovo::ParseULog, the parser ReadTelemetryFile uses
// for .ulg).
#include <cstddef>
#include <cstdint>

#include "aerovo/telemetry/telemetry_readers.h"
#include "fuzz_telemetry.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  aerovo::fuzz::FuzzTelemetryReader(
      data, size,
      [](std::istream& in, const std::string& name, const aerovo::TelemetryReadOptions& o) {
        return aerovo::ParseULog(in, name, o);
      });
  return 0;
}
