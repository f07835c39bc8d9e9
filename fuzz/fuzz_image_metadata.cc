// libFuzzer target: EXIF/XMP metadata of photos (aerovo::ParseImageMetadata: Exiv2 from memory,
// then the same extraction and range checks ReadImageMetadata applies to files), followed by
// TelemetryFromImages as `aerovo run` does for a photo folder. Exiv2 itself is Debian's
// uninstrumented build: the fuzzer's coverage feedback comes from aerovo's code only, but ASan
// still sees Exiv2's heap (leaks, double frees) and every exception escaping it.
// The same bytes, written to a file of a private temporary folder, go through CheckImageFile
// (frames/image_file.h: signature, end marker, the pixel size in the header), which reads every
// photo of a folder before anything else and never throws: it says the problem or finds none,
// and a size over kMaxImagePixels is always a problem.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "aerovo/core/error.h"
#include "aerovo/frames/image_file.h"
#include "aerovo/frames/image_metadata.h"
#include "fuzz_files.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path = aerovo::fuzz::MakeFolder("image_metadata") + "photo";
  aerovo::fuzz::WriteInput(path, data, size);
  const aerovo::ImageFileCheck c = aerovo::CheckImageFile(path);
  if (c.size_bytes != size) std::abort();
  if (c.problem.empty() && c.format.empty()) std::abort();
  if (static_cast<double>(c.width_px) * c.height_px > aerovo::kMaxImagePixels &&
      c.problem.empty()) {
    std::abort();
  }
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
