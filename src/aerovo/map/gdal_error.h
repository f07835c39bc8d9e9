// GDAL's last error message, for the map module's error texts (the sources that call GDAL:
// map_info.cc, map_build.cc, map_pixels.cc). Internal to the module; GDAL stays private.
#pragma once

#include <string>

namespace aerovo::map::internal {

/// CPLGetLastErrorMsg() of the calling thread, or `fallback` when GDAL has no message.
std::string LastGdalError(const std::string& fallback);

}  // namespace aerovo::map::internal
