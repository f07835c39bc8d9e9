#include "aerovo/telemetry/srt_writer.h"

#include <cmath>
#include <cstdint>

#include <fmt/format.h>

namespace aerovo {

std::string SrtTimestamp(double t_s) {
  const std::int64_t ms = std::llround(t_s * 1000);
  return fmt::format("{:02d}:{:02d}:{:02d},{:03d}", ms / 3600000, (ms / 60000) % 60,
                     (ms / 1000) % 60, ms % 1000);
}

std::string FormatDjiSrtEntry(const DjiSrtEntry& e) {
  return fmt::format(
      "{}\n{} --> {}\n<font size=\"28\">FrameCnt: {}, DiffTime: {}ms\n{}\n"
      "[iso: 100] [shutter: 1/1000.0] [fnum: 2.8] [ev: 0] [color_md: default] "
      "[focal_len: {:.2f}] [latitude: {:.6f}] [longitude: {:.6f}] [rel_alt: {:.3f} "
      "abs_alt: {:.3f}] {}[ct: 5500] </font>\n\n",
      e.index, SrtTimestamp(e.start_s), SrtTimestamp(e.end_s), e.index, e.diff_ms, e.date_time,
      e.focal_35mm_mm, e.position.lat_deg, e.position.lon_deg, e.rel_alt_m, e.position.alt_m,
      e.gimbal_pitch_deg || e.gimbal_roll_deg
          ? fmt::format("[gb_pitch: {:.1f} gb_roll: {:.1f}] ", e.gimbal_pitch_deg.value_or(-90.0),
                        e.gimbal_roll_deg.value_or(0.0))
          : std::string());
}

}  // namespace aerovo
