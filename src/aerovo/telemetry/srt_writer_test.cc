#include "aerovo/telemetry/srt_writer.h"

#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "aerovo/telemetry/telemetry_readers.h"

namespace aerovo::srt_writer_test {
namespace {

DjiSrtEntry Entry(int index, double t_s) {
  DjiSrtEntry e;
  e.index = index;
  e.start_s = t_s;
  e.end_s = t_s + 1.0 / 30.0;
  e.diff_ms = 33;
  e.date_time = "2026-05-01 10:00:00.000";
  e.focal_35mm_mm = 25.158279562990664;
  e.position = GeoPoint{43.53934012, 6.55162849, 400.0004};
  e.rel_alt_m = 100.0004;
  return e;
}

TEST(SrtWriter, TheDjiBracketedFormat) {
  EXPECT_EQ(FormatDjiSrtEntry(Entry(1, 0.0)),
            "1\n00:00:00,000 --> 00:00:00,033\n<font size=\"28\">FrameCnt: 1, DiffTime: 33ms\n"
            "2026-05-01 10:00:00.000\n[iso: 100] [shutter: 1/1000.0] [fnum: 2.8] [ev: 0] "
            "[color_md: default] [focal_len: 25.16] [latitude: 43.539340] [longitude: 6.551628] "
            "[rel_alt: 100.000 abs_alt: 400.000] [ct: 5500] </font>\n\n");
  EXPECT_EQ(SrtTimestamp(3723.4567), "01:02:03,457");
}

TEST(SrtWriter, ReadsBackWithTheSrtReader) {
  const std::string text =
      FormatDjiSrtEntry(Entry(1, 0.0)) + FormatDjiSrtEntry(Entry(2, 1.0 / 30.0));
  std::istringstream in(text);
  const TelemetryReadResult r = ParseDjiSrt(in, "written.srt");
  ASSERT_EQ(r.telemetry.size(), 2u);
  const TelemetrySample& s = r.telemetry.samples()[1];
  EXPECT_NEAR(s.time_s, 0.033, 1e-9);
  EXPECT_EQ(s.frame_index, 1);
  EXPECT_NEAR(s.lat_deg, 43.539340, 1e-9);
  EXPECT_NEAR(s.lon_deg, 6.551628, 1e-9);
  ASSERT_TRUE(s.rel_alt_m && s.abs_alt_m && s.focal_length_35mm_mm);
  EXPECT_NEAR(*s.rel_alt_m, 100.0, 1e-9);
  EXPECT_NEAR(*s.abs_alt_m, 400.0, 1e-9);
  EXPECT_NEAR(*s.focal_length_35mm_mm, 25.16, 1e-9);
}

}  // namespace
}  // namespace aerovo::srt_writer_test
