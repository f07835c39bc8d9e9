// libFuzzer target: EXIF/XMP metadata of photos (aerovo::ParseImageMetadata: Exiv2 from memory,
// then the same extraction and range checks ReadImageMetadata applies to files), followed by
// TelemetryFromImages as `aerovo run` does for a photo folder. Exiv2 itself is Debian's
// uninstrumented build: the fuzzer's coverage feedback comes from aerovo's code only, but ASan
// still sees Exiv2's heap (leaks, double frees) and every exception escaping it.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "aerovo/core/error.h"
#include "aerovo/frames/image_metadata.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const aerovo::ImageMetadata m = aerovo::ParseImageMetadata(data, size, "fuzz.jpg");
    if (m.HasGps()) {
      if (!(*m.lat_deg >= -90.0 && *m.lat_deg <= 90.0)) std::abort();
      if (!(*m.lon_deg >= -180.0 && *m.lon_deg <= 180.0)) std::abort();
    }
    (void)aerovo::TelemetryFromImages({m, m}, aerovo::TelemetryReadOptions{true, 3});
  } catch (const aerovo::InputError&) {
  }
  return 0;
}
