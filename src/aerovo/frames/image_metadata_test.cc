#include "aerovo/frames/image_metadata.h"

#include <fstream>
#include <initializer_list>
#include <iterator>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "aerovo/core/error.h"
#include "aerovo/core/testing.h"
#include "aerovo/frames/exif_test_writer.h"
#include "aerovo/frames/image_test_util.h"
#include "aerovo/telemetry/io_test_util.h"

namespace aerovo::image_metadata_test {
namespace {

using io_test::ExpectInputError;
using ::testing::HasSubstr;

// Values cross-checked with Exiv2's own tag dump (exiv2 -pa equivalent through the library):
// GPSLatitude 28/1 2/1 285116/10000 N, GPSLongitude 82/1 41/1 545072/10000 W, GPSAltitude
// 5677/1000 with GPSAltitudeRef 1, DateTimeOriginal 2018:04:29 12:06:46, FocalLength 361/100,
// FocalLengthIn35mmFilm 20, 800x600, Make DJI, Model FC300S. No XMP.
TEST(ImageMetadata, TampaPhantom3) {
  AEROVO_REQUIRE_SHARED(path, "data/flights/tampa-phantom3/DJI_0054.JPG");
  const ImageMetadata m = ReadImageMetadata(path);
  EXPECT_EQ(m.width_px, 800);
  EXPECT_EQ(m.height_px, 600);
  EXPECT_EQ(m.make, "DJI");
  EXPECT_EQ(m.model, "FC300S");
  ASSERT_TRUE(m.HasGps());
  EXPECT_NEAR(*m.lat_deg, 28.0 + 2.0 / 60.0 + 28.5116 / 3600.0, 1e-10);      // 28.041253 N
  EXPECT_NEAR(*m.lon_deg, -(82.0 + 41.0 / 60.0 + 54.5072 / 3600.0), 1e-10);  // 82.698474 W
  EXPECT_NEAR(*m.gps_alt_m, -5.677, 1e-9);  // "below sea level": the invalid altitude
  ASSERT_TRUE(m.capture_unix_time_s);
  EXPECT_DOUBLE_EQ(*m.capture_unix_time_s, 1525003606.0);  // 2018-04-29 12:06:46
  EXPECT_DOUBLE_EQ(*m.focal_length_mm, 3.61);
  EXPECT_DOUBLE_EQ(*m.focal_length_35mm_mm, 20.0);
  EXPECT_FALSE(m.rel_alt_m);
  EXPECT_FALSE(m.gimbal_yaw_deg);
}

// XMP drone-dji values as stored: RelativeAltitude +44.47, AbsoluteAltitude +349.58,
// GimbalYawDegree +106.80, GimbalPitchDegree -90.00, FlightYawDegree +107.00,
// FlightRollDegree +0.80, CalibratedFocalLength 1913.333374 (800, 650 centre).
TEST(ImageMetadata, TurinP4Multispectral) {
  AEROVO_REQUIRE_SHARED(path, "data/flights/turin-p4m/DJI_0010.JPG");
  const ImageMetadata m = ReadImageMetadata(path);
  EXPECT_EQ(m.width_px, 1600);
  EXPECT_EQ(m.height_px, 1300);
  EXPECT_EQ(m.model, "FC6360");
  EXPECT_NEAR(*m.lat_deg, 45.0 + 1.0 / 60.0 + 53.7444 / 3600.0, 1e-10);
  EXPECT_NEAR(*m.lon_deg, 7.0 + 37.0 / 60.0 + 13.6771 / 3600.0, 1e-10);
  EXPECT_NEAR(*m.lat_deg, 45.03159568, 1e-7);  // XMP GpsLatitude agrees
  EXPECT_NEAR(*m.lon_deg, 7.62046587, 1e-7);
  EXPECT_NEAR(*m.gps_alt_m, 349.583, 1e-9);
  EXPECT_DOUBLE_EQ(*m.rel_alt_m, 44.47);
  EXPECT_DOUBLE_EQ(*m.abs_alt_m, 349.58);
  EXPECT_DOUBLE_EQ(*m.gimbal_yaw_deg, 106.8);
  EXPECT_DOUBLE_EQ(*m.gimbal_pitch_deg, -90.0);
  EXPECT_DOUBLE_EQ(*m.gimbal_roll_deg, 0.0);
  EXPECT_DOUBLE_EQ(*m.flight_yaw_deg, 107.0);
  EXPECT_DOUBLE_EQ(*m.flight_roll_deg, 0.8);
  EXPECT_DOUBLE_EQ(*m.focal_length_mm, 5.74);
  EXPECT_DOUBLE_EQ(*m.focal_length_35mm_mm, 40.0);
  EXPECT_NEAR(*m.calibrated_focal_px, 1913.333374, 1e-6);
  EXPECT_DOUBLE_EQ(*m.calibrated_cx_px, 800.0);
  EXPECT_DOUBLE_EQ(*m.calibrated_cy_px, 650.0);
  EXPECT_DOUBLE_EQ(*m.capture_unix_time_s, 1769435417.0);  // 2026-01-26 13:50:17
  // The RGB camera of the rig: a capture id shared with the five band TIFFs, no band name.
  EXPECT_EQ(m.capture_id, "27b14018528c11f08d087d2ed18fec73");
  EXPECT_EQ(m.band_name, "");
  EXPECT_FALSE(m.rig_camera_index);

  const TelemetrySample s = m.ToSample();
  EXPECT_DOUBLE_EQ(*s.abs_alt_m, 349.58);  // XMP absolute altitude preferred
  EXPECT_DOUBLE_EQ(*s.CameraYawDeg(), 106.8);
}

TEST(ImageMetadata, TurinSequenceTelemetry) {
  AEROVO_REQUIRE_SHARED(dir, "data/flights/turin-p4m");
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::directory_iterator(dir)) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  std::vector<ImageMetadata> metas;
  for (const auto& f : files) metas.push_back(ReadImageMetadata(f));
  ASSERT_EQ(metas.size(), 32u);
  const TelemetryReadResult r = TelemetryFromImages(metas);
  EXPECT_EQ(r.records, 32);
  EXPECT_EQ(r.no_fix_records, 0);
  for (const TelemetrySample& s : r.telemetry.samples()) {
    ASSERT_TRUE(s.rel_alt_m);
    EXPECT_NEAR(*s.rel_alt_m, 44.5, 0.5);  // README: RelativeAltitude 44.5 m
    EXPECT_NEAR(*s.gimbal_pitch_deg, -90.0, 0.5);
  }
  EXPECT_EQ(r.telemetry[0].frame_index, 0);
  EXPECT_DOUBLE_EQ(r.telemetry[0].time_s, 0.0);
  EXPECT_GT(r.telemetry.end_time_s(), 0.0);
}

TEST(ImageMetadata, SyntheticTagsRoundTrip) {
  io_test::TempDir dir("aerovo_exif");
  const auto path = dir / "a.jpg";
  io_test::WriteJpegWithTags(
      path, io_test::TextureImage(64, 48, 1),
      {{"Exif.GPSInfo.GPSLatitude", "33/1 52/1 0/1"},
       {"Exif.GPSInfo.GPSLatitudeRef", "S"},
       {"Exif.GPSInfo.GPSLongitude", "151/1 12/1 36/1"},
       {"Exif.GPSInfo.GPSLongitudeRef", "E"},
       {"Exif.Photo.DateTimeOriginal", "2023:05:01 12:00:00"},
       {"Exif.Photo.SubSecTimeOriginal", "25"},
       {"Exif.Photo.FocalLengthIn35mmFilm", "24"}},
      {{"Xmp.drone-dji.RelativeAltitude", "+80.25"}, {"Xmp.drone-dji.FlightYawDegree", "-45.5"}});
  const ImageMetadata m = ReadImageMetadata(path);
  EXPECT_EQ(m.width_px, 64);
  EXPECT_EQ(m.height_px, 48);
  EXPECT_NEAR(*m.lat_deg, -(33.0 + 52.0 / 60.0), 1e-12);
  EXPECT_NEAR(*m.lon_deg, 151.0 + 12.0 / 60.0 + 36.0 / 3600.0, 1e-12);
  EXPECT_NEAR(*m.capture_unix_time_s, 1682942400.25, 1e-6);
  EXPECT_DOUBLE_EQ(*m.focal_length_35mm_mm, 24.0);
  EXPECT_DOUBLE_EQ(*m.rel_alt_m, 80.25);
  EXPECT_DOUBLE_EQ(*m.flight_yaw_deg, -45.5);
  EXPECT_FALSE(m.gps_alt_m);

  // The same bytes through the in-memory entry point.
  std::ifstream in(path, std::ios::binary);
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                        std::istreambuf_iterator<char>());
  const ImageMetadata mm = ParseImageMetadata(bytes.data(), bytes.size(), "mem");
  EXPECT_EQ(*mm.lat_deg, *m.lat_deg);
  EXPECT_EQ(mm.source, "mem");
}

using io_test::Ascii;
using io_test::Rationals;
using io_test::TiffEntry;
using io_test::WriteJpegWithExif;

// A JPEG as DJI Zenmuse XT/H20T thermal cameras write it: the XMP packet in the TIFF tag 0x02bc
// (XMLPacket, BYTE) of IFD0, after Make and Model.
void WriteJpegWithExifXmlPacket(const std::filesystem::path& path, const std::string& make,
                                const std::string& model, const std::string& packet) {
  WriteJpegWithExif(path, io_test::TextureImage(64, 48, 3),
                    {Ascii(0x010f, make),
                     Ascii(0x0110, model),
                     {0x02bc, 1, static_cast<unsigned>(packet.size()), packet, {}}});
}

const char* const kXt2Packet =
    R"(<?xpacket begin="" id="W5M0MpCehiHzreSzNTczkc9d"?>)"
    R"(<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#">)"
    R"(<rdf:Description rdf:about="DJI Meta Data" xmlns:drone-dji="http://www.dji.com/drone-dji/1.0/")"
    R"( drone-dji:RelativeAltitude="+100.20" drone-dji:AbsoluteAltitude="+312.5")"
    R"( drone-dji:GimbalPitchDegree="-89.90" drone-dji:GimbalYawDegree="+12.30")"
    R"( drone-dji:FlightYawDegree="+11.80" drone-dji:FlightPitchDegree="+2.10" drone-dji:FlightRollDegree="-1.40"/>)"
    R"(</rdf:RDF></x:xmpmeta><?xpacket end="w"?>)";

TEST(ImageMetadata, XmpPacketInsideExifTag0x02bc) {
  io_test::TempDir dir("aerovo_xt2");
  const auto path = dir / "DJI_0001_R.JPG";
  WriteJpegWithExifXmlPacket(path, "DJI", "XT2", std::string(kXt2Packet) + std::string(3, '\0'));
  const ImageMetadata m = ReadImageMetadata(path);
  EXPECT_EQ(m.make, "DJI");
  EXPECT_EQ(m.model, "XT2");
  EXPECT_TRUE(m.xmp_from_exif_packet);
  ASSERT_TRUE(m.rel_alt_m);
  EXPECT_DOUBLE_EQ(*m.rel_alt_m, 100.2);
  EXPECT_DOUBLE_EQ(*m.abs_alt_m, 312.5);
  EXPECT_DOUBLE_EQ(*m.gimbal_pitch_deg, -89.9);
  EXPECT_DOUBLE_EQ(*m.gimbal_yaw_deg, 12.3);
  EXPECT_DOUBLE_EQ(*m.flight_pitch_deg, 2.1);
  EXPECT_DOUBLE_EQ(*m.flight_roll_deg, -1.4);

  // A packet that is not XMP is an error naming the photo and the tag, not silently ignored.
  const auto bad = dir / "bad.jpg";
  WriteJpegWithExifXmlPacket(bad, "DJI", "XT2", "<x:xmpmeta><rdf:RDF><unclosed");
  ExpectInputError([&] { ReadImageMetadata(bad); }, {"bad.jpg", "0x02bc", "does not parse"});

  // Without the packet, nothing is made up.
  const auto none = dir / "none.jpg";
  WriteJpegWithExifXmlPacket(none, "DJI", "XT2", std::string(8, '\0'));
  const ImageMetadata mn = ReadImageMetadata(none);
  EXPECT_FALSE(mn.xmp_from_exif_packet);
  EXPECT_FALSE(mn.rel_alt_m);
}

// A photo as a DJI Zenmuse XT2 writes it: IFD0 with Make, Model, the Exif sub-IFD pointer and
// the GPS IFD pointer; the XMP packet in tag 0x02bc of the Exif sub-IFD (exiftool
// "ExifIFD:ApplicationNotes"), BYTE or UNDEFINED; GPS with an altitude above sea level only.
// Before, aerovo read IFD0's 0x02bc alone and refused such a flight with "only an altitude above
// sea level (558.5 m)": the relative altitude and the gimbal angles must come from the packet.
TEST(ImageMetadata, XmpPacketInTheExifSubIfdApplicationNotes) {
  io_test::TempDir dir("aerovo_xt2_exififd");
  const std::string packet =
      R"(<?xpacket begin="" id="W5M0MpCehiHzreSzNTczkc9d"?>)"
      R"(<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#">)"
      R"(<rdf:Description rdf:about="DJI Meta Data" xmlns:drone-dji="http://www.dji.com/drone-dji/1.0/")"
      R"( drone-dji:AbsoluteAltitude="+558.50" drone-dji:RelativeAltitude="+100.00")"
      R"( drone-dji:GimbalRollDegree="+0.00" drone-dji:GimbalYawDegree="-24.70" drone-dji:GimbalPitchDegree="-90.00")"
      R"( drone-dji:FlightRollDegree="+1.20" drone-dji:FlightYawDegree="-25.10" drone-dji:FlightPitchDegree="-3.40"/>)"
      R"(</rdf:RDF></x:xmpmeta><?xpacket end="w"?>)";
  const std::vector<TiffEntry> gps = {
      {0x0001, 2, 2, std::string("N\0", 2), {}},                         // GPSLatitudeRef
      {0x0002, 5, 3, Rationals({{45, 1}, {30, 1}, {36000, 1000}}), {}},  // GPSLatitude
      {0x0003, 2, 2, std::string("E\0", 2), {}},                         // GPSLongitudeRef
      {0x0004, 5, 3, Rationals({{7, 1}, {12, 1}, {18000, 1000}}), {}},   // GPSLongitude
      {0x0005, 1, 1, std::string(1, '\0'), {}},                          // above sea level
      {0x0006, 5, 1, Rationals({{5585, 10}}), {}}};                      // GPSAltitude
  for (const unsigned type : {1u, 7u}) {                                 // BYTE, UNDEFINED
    SCOPED_TRACE(type);
    const std::vector<TiffEntry> exif_ifd = {
        {0x02bc, type, static_cast<unsigned>(packet.size()), packet, {}},  // ApplicationNotes
        {0x9000, 7, 4, "0230", {}}};                                       // ExifVersion
    const auto path = dir / fmt::format("DJI_0001_R_{}.JPG", type);
    WriteJpegWithExif(path, io_test::TextureImage(64, 48, 3),
                      {Ascii(0x010f, "DJI"),
                       Ascii(0x0110, "XT2"),
                       {0x8769, 4, 1, "", exif_ifd},
                       {0x8825, 4, 1, "", gps}});
    const ImageMetadata m = ReadImageMetadata(path);
    EXPECT_EQ(m.model, "XT2");
    EXPECT_EQ(m.xmp_source, ImageMetadata::XmpSource::kExifIfdApplicationNotes);
    EXPECT_TRUE(m.xmp_from_exif_packet);
    ASSERT_TRUE(m.rel_alt_m);
    EXPECT_DOUBLE_EQ(*m.rel_alt_m, 100.0);
    EXPECT_DOUBLE_EQ(*m.abs_alt_m, 558.5);
    EXPECT_DOUBLE_EQ(*m.gps_alt_m, 558.5);
    EXPECT_DOUBLE_EQ(*m.gimbal_pitch_deg, -90.0);
    EXPECT_DOUBLE_EQ(*m.gimbal_yaw_deg, -24.7);
    EXPECT_DOUBLE_EQ(*m.flight_yaw_deg, -25.1);
    EXPECT_DOUBLE_EQ(*m.flight_pitch_deg, -3.4);
    EXPECT_NEAR(*m.lat_deg, 45.51, 1e-9);
    EXPECT_NEAR(*m.lon_deg, 7.205, 1e-9);
    // The telemetry of the photo: its relative altitude, and its file named as the origin.
    const TelemetryReadResult t = TelemetryFromImages({m});
    ASSERT_EQ(t.records, 1);
    EXPECT_DOUBLE_EQ(*t.telemetry[0].rel_alt_m, 100.0);
    EXPECT_EQ(t.telemetry[0].origin, path.string());
  }

  // The same packet in IFD0's XMLPacket is read from there (and said so).
  const auto ifd0 = dir / "ifd0.jpg";
  WriteJpegWithExifXmlPacket(ifd0, "DJI", "XT2", packet);
  const ImageMetadata m0 = ReadImageMetadata(ifd0);
  EXPECT_EQ(m0.xmp_source, ImageMetadata::XmpSource::kIfd0XmlPacket);
  EXPECT_DOUBLE_EQ(*m0.rel_alt_m, 100.0);

  // A broken packet in the Exif sub-IFD is an error naming the photo and the place.
  const auto bad = dir / "bad.jpg";
  WriteJpegWithExif(
      bad, io_test::TextureImage(64, 48, 3),
      {Ascii(0x010f, "DJI"), {0x8769, 4, 1, "", {{0x02bc, 7, 12, "<x:xmpmeta><", {}}}}});
  ExpectInputError([&] { ReadImageMetadata(bad); },
                   {"bad.jpg", "0x02bc", "Exif sub-IFD ApplicationNotes", "does not parse"});

  // A photo written by Exiv2 with an APP1 XMP segment: read from there.
  const auto app1 = dir / "app1.jpg";
  io_test::WriteJpegWithTags(app1, io_test::TextureImage(64, 48, 1), {{"Exif.Image.Make", "DJI"}},
                             {{"Xmp.drone-dji.RelativeAltitude", "+42.0"}});
  const ImageMetadata ma = ReadImageMetadata(app1);
  EXPECT_EQ(ma.xmp_source, ImageMetadata::XmpSource::kApp1Segment);
  EXPECT_FALSE(ma.xmp_from_exif_packet);
  EXPECT_DOUBLE_EQ(*ma.rel_alt_m, 42.0);
}

// XMP of other vendors (docs/inputs.md, "XMP of other vendors"): each packet is written into
// the photo's APP1 segment byte for byte, and the values must come out in DJI's convention.

const char* const kPacketBegin =
    "<?xpacket begin=\"\xEF\xBB\xBF\" id=\"W5M0MpCehiHzreSzNTczkc9d\"?>\n"
    "<x:xmpmeta xmlns:x=\"adobe:ns:meta/\">\n"
    " <rdf:RDF xmlns:rdf=\"http://www.w3.org/1999/02/22-rdf-syntax-ns#\">\n";
const char* const kPacketEnd = " </rdf:RDF>\n</x:xmpmeta>\n<?xpacket end=\"w\"?>";

// A Parrot ANAFI Ai photo's XMP: one rdf:Description holding Parrot's drone-parrot tags and the
// Pix4D Camera tags, as elements. The values are the examples of Parrot's table ("Embedded Photo
// Metadata", developer.parrot.com/docs/groundsdk-tools/photo-metadata.html), all of one photo:
// the camera pitched 52 degrees below the horizon, drone-parrot:CameraPitchDegree -51.988888
// (NED, DJI's convention) beside Camera:Pitch 38.011101 (Pix4D's, 0 = nadir); the height above
// the ground written as a fraction.
std::string ParrotAnafiPacket(const std::string& pitch_deg = "-51.988888") {
  return std::string(kPacketBegin) +
         "  <rdf:Description rdf:about=\"\"\n"
         "    xmlns:xmp=\"http://ns.adobe.com/xap/1.0/\"\n"
         "    xmlns:tiff=\"http://ns.adobe.com/tiff/1.0/\"\n"
         "    xmlns:Camera=\"http://pix4d.com/camera/1.0/\"\n"
         "    xmlns:drone-parrot=\"http://www.parrot.com/drone-parrot/1.0/\">\n"
         "   <xmp:CreateDate>2021-10-22T11:30:09.205000+02:00</xmp:CreateDate>\n"
         "   <tiff:Make>Parrot</tiff:Make>\n"
         "   <tiff:Model>ANAFI Ai</tiff:Model>\n"
         "   <Camera:GPSXYAccuracy>845389/2097152</Camera:GPSXYAccuracy>\n"
         "   <Camera:ModelType>perspective</Camera:ModelType>\n"
         "   <Camera:Roll>-0.041258</Camera:Roll>\n"
         "   <Camera:Pitch>38.011101</Camera:Pitch>\n"
         "   <Camera:Yaw>146.781036</Camera:Yaw>\n"
         "   <Camera:AboveGroundAltitude>11485529/262144</Camera:AboveGroundAltitude>\n"
         "   <drone-parrot:CameraRollDegree>-0.052789</drone-parrot:CameraRollDegree>\n"
         "   <drone-parrot:CameraPitchDegree>" +
         pitch_deg +
         "</drone-parrot:CameraPitchDegree>\n"
         "   <drone-parrot:CameraYawDegree>146.848038</drone-parrot:CameraYawDegree>\n"
         "   <drone-parrot:SerialNumber>PI040416BA8G059745</drone-parrot:SerialNumber>\n"
         "  </rdf:Description>\n" +
         kPacketEnd;
}

// Before, such a photo had no relative altitude and no gimbal angles: a folder of them stopped
// with "only an altitude above sea level", and an oblique camera ran as nadir.
TEST(ImageMetadataVendors, ParrotAnafiDroneParrotAnglesAndPix4dHeight) {
  io_test::TempDir dir("aerovo_xmp_parrot");
  const auto path = dir / "P0010001.JPG";
  io_test::WriteJpegWithXmpPacket(path, io_test::TextureImage(64, 48, 5), ParrotAnafiPacket());
  const ImageMetadata m = ReadImageMetadata(path);
  EXPECT_EQ(m.xmp_source, ImageMetadata::XmpSource::kApp1Segment);
  EXPECT_EQ(m.xmp_vendor, ImageMetadata::XmpVendor::kParrot);
  ASSERT_TRUE(m.rel_alt_m);
  EXPECT_DOUBLE_EQ(*m.rel_alt_m, 11485529.0 / 262144.0);  // 43.81 m
  // Parrot's own NED angles, as written (not Camera:*, Pix4D's view of the same attitude).
  EXPECT_DOUBLE_EQ(*m.gimbal_pitch_deg, -51.988888);
  EXPECT_DOUBLE_EQ(*m.gimbal_yaw_deg, 146.848038);
  EXPECT_DOUBLE_EQ(*m.gimbal_roll_deg, -0.052789);
  EXPECT_FALSE(m.abs_alt_m);
  EXPECT_FALSE(m.flight_yaw_deg);
  EXPECT_STREQ(XmpVendorName(m.xmp_vendor), "Parrot drone-parrot");

  // The same packet in the TIFF tag 0x02bc of IFD0 (where Parrot's DNG files have an XMLPacket).
  const auto ifd0 = dir / "ifd0.jpg";
  WriteJpegWithExifXmlPacket(ifd0, "Parrot", "ANAFI Ai", ParrotAnafiPacket());
  const ImageMetadata m0 = ReadImageMetadata(ifd0);
  EXPECT_EQ(m0.xmp_source, ImageMetadata::XmpSource::kIfd0XmlPacket);
  EXPECT_EQ(m0.xmp_vendor, ImageMetadata::XmpVendor::kParrot);
  EXPECT_DOUBLE_EQ(*m0.gimbal_pitch_deg, -51.988888);
  EXPECT_DOUBLE_EQ(*m0.rel_alt_m, 11485529.0 / 262144.0);
}

// A MicaSense RedEdge-MX band TIFF: its XMP in tag 700 (io_test::MicaSenseBandPacket).
std::string MicaSenseTiffPacket(const std::string& band, const std::string& index) {
  return io_test::MicaSenseBandPacket("DFj0YDYQsRJd6hDUj7qZ", band, index);
}

TEST(ImageMetadataVendors, MicaSenseBandTiffNamesItsBandAndCapture) {
  io_test::TempDir dir("aerovo_xmp_micasense");
  cv::Mat band(36, 48, CV_16UC1, cv::Scalar(1000));
  std::map<std::string, std::string> exif = {{"Exif.Image.Make", "MicaSense"},
                                             {"Exif.Image.Model", "RedEdge-M"},
                                             {"Exif.Photo.FocalLength", "55/10"},
                                             {"Exif.Photo.FocalPlaneXResolution", "26667/100"},
                                             {"Exif.Photo.FocalPlaneResolutionUnit", "4"}};
  io_test::WriteTiffWithXmpPacket(dir / "IMG_0001_1.tif", band, exif,
                                  MicaSenseTiffPacket("Blue", "0"));
  const ImageMetadata m = ReadImageMetadata(dir / "IMG_0001_1.tif");
  EXPECT_EQ(m.band_name, "Blue");
  EXPECT_EQ(m.capture_id, "DFj0YDYQsRJd6hDUj7qZ");
  EXPECT_EQ(m.rig_camera_index, 0);
  EXPECT_EQ(m.width_px, 48);
  // No 35 mm equivalent: the focal length over the pixel pitch (frames/camera.h).
  EXPECT_DOUBLE_EQ(*m.focal_length_mm, 5.5);
  EXPECT_DOUBLE_EQ(*m.focal_plane_px_per_mm, 266.67);
  EXPECT_FALSE(m.focal_length_35mm_mm);
  // The resolution's unit: centimetres (EXIF's 3), inches (2, and when absent); 7 is no unit.
  const auto pitch = [&](const std::string& name, const std::string& res, const char* unit) {
    std::map<std::string, std::string> e = exif;
    e["Exif.Photo.FocalPlaneXResolution"] = res;
    if (unit == nullptr) {
      e.erase("Exif.Photo.FocalPlaneResolutionUnit");
    } else {
      e["Exif.Photo.FocalPlaneResolutionUnit"] = unit;
    }
    io_test::WriteTiffWithXmpPacket(dir / name, band, e, MicaSenseTiffPacket("Blue", "0"));
    return ReadImageMetadata(dir / name).focal_plane_px_per_mm;
  };
  EXPECT_DOUBLE_EQ(*pitch("cm.tif", "26667/10", "3"), 266.67);
  EXPECT_DOUBLE_EQ(*pitch("inch.tif", "6773418/1000", nullptr), 6773.418 / 25.4);
  EXPECT_FALSE(pitch("unit7.tif", "26667/100", "7"));
  // TIFF/EP's place, IFD0, in micrometres.
  std::map<std::string, std::string> ep = exif;
  ep.erase("Exif.Photo.FocalPlaneXResolution");
  ep.erase("Exif.Photo.FocalPlaneResolutionUnit");
  ep["Exif.Image.FocalPlaneXResolution"] = "26667/100000";
  ep["Exif.Image.FocalPlaneResolutionUnit"] = "5";
  io_test::WriteTiffWithXmpPacket(dir / "tiff_ep.tif", band, ep, MicaSenseTiffPacket("Blue", "0"));
  EXPECT_NEAR(*ReadImageMetadata(dir / "tiff_ep.tif").focal_plane_px_per_mm, 266.67, 1e-9);
  // Its Camera namespace has no angles: no vendor's flight values.
  EXPECT_EQ(m.xmp_vendor, ImageMetadata::XmpVendor::kNone);
  EXPECT_EQ(ReadImageMetadata([&] {
              io_test::WriteTiffWithXmpPacket(dir / "IMG_0001_5.tif", band, exif,
                                              MicaSenseTiffPacket("Red edge", "4"));
              return dir / "IMG_0001_5.tif";
            }())
                .band_name,
            "Red edge");
  // What no camera writes is an error naming the file and the tag.
  io_test::WriteTiffWithXmpPacket(dir / "bad_index.tif", band, exif,
                                  MicaSenseTiffPacket("Blue", "1.5"));
  io_test::ExpectInputError([&] { ReadImageMetadata(dir / "bad_index.tif"); },
                            {"bad_index.tif", "Camera:RigCameraIndex 1.5"});
  io_test::WriteTiffWithXmpPacket(dir / "bad_name.tif", band, exif,
                                  MicaSenseTiffPacket("Blue&#x9;&#xA;NIR", "0"));
  io_test::ExpectInputError([&] { ReadImageMetadata(dir / "bad_name.tif"); },
                            {"bad_name.tif", "XMP Camera:BandName", "at most 64 printable"});
}

// Pix4D's Camera namespace alone, as exiftool writes it with its pix4d.config (single quotes,
// one rdf:Description per namespace, elements): Pix4D's convention is pitch 0 = nadir
// (support.pix4d.com/hc/en-us/articles/202558969), DJI's -90.
TEST(ImageMetadataVendors, Pix4dCameraNadirAndObliqueInDjiConvention) {
  io_test::TempDir dir("aerovo_xmp_pix4d");
  const auto write = [&](const std::string& name, const std::string& yaw, const std::string& pitch,
                         const std::string& roll,
                         const std::string& uri = "http://pix4d.com/camera/1.0/") {
    const std::string packet =
        std::string(kPacketBegin) + "  <rdf:Description rdf:about=''\n  xmlns:Camera='" + uri +
        "'>\n" + "  <Camera:Yaw>" + yaw + "</Camera:Yaw>\n" + "  <Camera:Pitch>" + pitch +
        "</Camera:Pitch>\n" + "  <Camera:Roll>" + roll + "</Camera:Roll>\n" +
        "  <Camera:BandName>\n   <rdf:Seq>\n    <rdf:li>NIR</rdf:li>\n   </rdf:Seq>\n"
        "  </Camera:BandName>\n" +
        "  </rdf:Description>\n" + kPacketEnd;
    io_test::WriteJpegWithXmpPacket(dir / name, io_test::TextureImage(48, 32, 6), packet);
    return ReadImageMetadata(dir / name);
  };
  const ImageMetadata nadir = write("nadir.jpg", "270", "0", "0");
  EXPECT_EQ(nadir.xmp_vendor, ImageMetadata::XmpVendor::kPix4dCamera);
  EXPECT_DOUBLE_EQ(*nadir.gimbal_pitch_deg, -90.0);
  EXPECT_DOUBLE_EQ(*nadir.gimbal_yaw_deg, 270.0);
  EXPECT_DOUBLE_EQ(*nadir.gimbal_roll_deg, 0.0);
  EXPECT_FALSE(nadir.rel_alt_m);

  // Parrot's example Camera:Pitch: 38.011101 from nadir = 51.988899 below the horizon.
  const ImageMetadata oblique = write("oblique.jpg", "146.781036", "38.011101", "-0.041258");
  EXPECT_NEAR(*oblique.gimbal_pitch_deg, -51.988899, 1e-9);
  EXPECT_DOUBLE_EQ(*oblique.gimbal_roll_deg, -0.041258);
  // Looking forward (90) is DJI's horizon (0); past nadir backwards (-10) is -100.
  EXPECT_NEAR(*write("forward.jpg", "0", "90", "0").gimbal_pitch_deg, 0.0, 1e-12);
  EXPECT_NEAR(*write("back.jpg", "0", "-10", "0").gimbal_pitch_deg, -100.0, 1e-12);
  // The URI as Pix4D's page spells it, without the final slash, is the same namespace to Exiv2.
  const ImageMetadata noslash = write("noslash.jpg", "10", "5", "1", "http://pix4d.com/camera/1.0");
  EXPECT_EQ(noslash.xmp_vendor, ImageMetadata::XmpVendor::kPix4dCamera);
  EXPECT_DOUBLE_EQ(*noslash.gimbal_pitch_deg, -85.0);

  // Attributes of rdf:Description (Exiv2's and the XMP toolkit's compact form), with the height.
  const auto attrs = dir / "attrs.jpg";
  io_test::WriteJpegWithXmpPacket(
      attrs, io_test::TextureImage(48, 32, 7),
      std::string(kPacketBegin) +
          "  <rdf:Description rdf:about=\"\" xmlns:Camera=\"http://pix4d.com/camera/1.0/\"\n"
          "    Camera:Yaw=\"-12.5\" Camera:Pitch=\"2.5\" Camera:Roll=\"1.25\"\n"
          "    Camera:AboveGroundAltitude=\"120.5\"/>\n" +
          kPacketEnd);
  const ImageMetadata ma = ReadImageMetadata(attrs);
  EXPECT_EQ(ma.xmp_vendor, ImageMetadata::XmpVendor::kPix4dCamera);
  EXPECT_DOUBLE_EQ(*ma.gimbal_yaw_deg, -12.5);
  EXPECT_DOUBLE_EQ(*ma.gimbal_pitch_deg, -87.5);
  EXPECT_DOUBLE_EQ(*ma.gimbal_roll_deg, 1.25);
  EXPECT_DOUBLE_EQ(*ma.rel_alt_m, 120.5);
}

// senseFly writes the same tag names with the prefix "Camera" under its own URI: read in
// Pix4D's convention, and not mistaken for Pix4D's namespace.
TEST(ImageMetadataVendors, SenseFlyCameraNamespace) {
  io_test::TempDir dir("aerovo_xmp_sensefly");
  const auto path = dir / "IMG_0001.JPG";
  io_test::WriteJpegWithXmpPacket(path, io_test::TextureImage(48, 32, 8),
                                  std::string(kPacketBegin) +
                                      "  <rdf:Description rdf:about=\"\"\n"
                                      "    xmlns:Camera=\"http://ns.sensefly.com/Camera/1.0/\">\n"
                                      "   <Camera:Yaw>87.3</Camera:Yaw>\n"
                                      "   <Camera:Pitch>4.2</Camera:Pitch>\n"
                                      "   <Camera:Roll>-3.1</Camera:Roll>\n"
                                      "  </rdf:Description>\n" +
                                      kPacketEnd);
  const ImageMetadata m = ReadImageMetadata(path);
  EXPECT_EQ(m.xmp_vendor, ImageMetadata::XmpVendor::kSenseFlyCamera);
  EXPECT_DOUBLE_EQ(*m.gimbal_yaw_deg, 87.3);
  EXPECT_NEAR(*m.gimbal_pitch_deg, -85.8, 1e-12);
  EXPECT_DOUBLE_EQ(*m.gimbal_roll_deg, -3.1);
}

// A photo whose packet has DJI's drone-dji values and another vendor's keeps the DJI values.
TEST(ImageMetadataVendors, DjiValuesWinOverOtherNamespaces) {
  io_test::TempDir dir("aerovo_xmp_both");
  const auto path = dir / "DJI_0001.JPG";
  io_test::WriteJpegWithXmpPacket(
      path, io_test::TextureImage(48, 32, 9),
      std::string(kPacketBegin) +
          "  <rdf:Description rdf:about=\"DJI Meta Data\"\n"
          "    xmlns:drone-dji=\"http://www.dji.com/drone-dji/1.0/\"\n"
          "    xmlns:Camera=\"http://pix4d.com/camera/1.0/\"\n"
          "    xmlns:drone-parrot=\"http://www.parrot.com/drone-parrot/1.0/\"\n"
          "   drone-dji:RelativeAltitude=\"+60.10\" drone-dji:GimbalPitchDegree=\"-45.00\"\n"
          "   drone-dji:GimbalYawDegree=\"+10.00\" Camera:Pitch=\"0\" Camera:Yaw=\"200\"\n"
          "   Camera:AboveGroundAltitude=\"99\" drone-parrot:CameraPitchDegree=\"-90\"/>\n" +
          kPacketEnd);
  const ImageMetadata m = ReadImageMetadata(path);
  EXPECT_EQ(m.xmp_vendor, ImageMetadata::XmpVendor::kDji);
  EXPECT_DOUBLE_EQ(*m.rel_alt_m, 60.1);
  EXPECT_DOUBLE_EQ(*m.gimbal_pitch_deg, -45.0);
  EXPECT_DOUBLE_EQ(*m.gimbal_yaw_deg, 10.0);
  EXPECT_FALSE(m.gimbal_roll_deg);  // not taken from another namespace either
}

// A vendor value that is not a number, has a zero denominator or is out of range stops the
// read with an error naming the photo and the tag, as the DJI values do.
TEST(ImageMetadataVendors, MalformedValuesNameTheTag) {
  io_test::TempDir dir("aerovo_xmp_bad");
  const auto write = [&](const std::string& name, const std::string& packet) {
    io_test::WriteJpegWithXmpPacket(dir / name, io_test::TextureImage(32, 32, 10), packet);
    return dir / name;
  };
  ExpectInputError([&] { ReadImageMetadata(write("pitch.jpg", ParrotAnafiPacket("down"))); },
                   {"pitch.jpg: XMP drone-parrot:CameraPitchDegree 'down' is not a number"});
  const auto pix4d = [&](const std::string& attrs) {
    return std::string(kPacketBegin) +
           "  <rdf:Description rdf:about=\"\" xmlns:Camera=\"http://pix4d.com/camera/1.0/\" " +
           attrs + "/>\n" + kPacketEnd;
  };
  ExpectInputError(
      [&] { ReadImageMetadata(write("den.jpg", pix4d("Camera:AboveGroundAltitude=\"43/0\""))); },
      {"den.jpg: XMP Camera:AboveGroundAltitude '43/0' has a zero denominator"});
  ExpectInputError([&] { ReadImageMetadata(write("yaw.jpg", pix4d("Camera:Yaw=\"400\""))); },
                   {"yaw.jpg: XMP Camera:Yaw 400 out of range [-360, 360]"});
  ExpectInputError([&] { ReadImageMetadata(write("frac.jpg", pix4d("Camera:Pitch=\"1/x\""))); },
                   {"frac.jpg: XMP Camera:Pitch '1/x' is not a number"});
}

TEST(ImageMetadata, BadValuesAndBadFilesNameTheFile) {
  io_test::TempDir dir("aerovo_exif_bad");
  const auto img = io_test::TextureImage(32, 32, 2);
  io_test::WriteJpegWithTags(dir / "lat95.jpg", img,
                             {{"Exif.GPSInfo.GPSLatitude", "95/1 0/1 0/1"},
                              {"Exif.GPSInfo.GPSLatitudeRef", "N"},
                              {"Exif.GPSInfo.GPSLongitude", "10/1 0/1 0/1"},
                              {"Exif.GPSInfo.GPSLongitudeRef", "E"}});
  ExpectInputError([&] { ReadImageMetadata(dir / "lat95.jpg"); },
                   {"lat95.jpg", "EXIF GPS latitude 95 out of range [-90, 90]"});
  io_test::WriteJpegWithTags(dir / "zero.jpg", img,
                             {{"Exif.GPSInfo.GPSLatitude", "45/0 0/1 0/1"},
                              {"Exif.GPSInfo.GPSLongitude", "10/1 0/1 0/1"}});
  ExpectInputError([&] { ReadImageMetadata(dir / "zero.jpg"); }, {"zero.jpg", "zero denominator"});
  io_test::WriteJpegWithTags(dir / "two.jpg", img, {{"Exif.GPSInfo.GPSLatitude", "45/1 3/1"}});
  ExpectInputError([&] { ReadImageMetadata(dir / "two.jpg"); },
                   {"two.jpg", "2 components (expected 3)"});
  io_test::WriteJpegWithTags(dir / "xmp.jpg", img, {},
                             {{"Xmp.drone-dji.RelativeAltitude", "high"}});
  ExpectInputError([&] { ReadImageMetadata(dir / "xmp.jpg"); },
                   {"xmp.jpg", "RelativeAltitude 'high' is not a number"});

  std::ofstream(dir / "empty.jpg").close();
  ExpectInputError([&] { ReadImageMetadata(dir / "empty.jpg"); },
                   {"cannot read metadata of", "empty.jpg"});
  std::ofstream(dir / "text.jpg") << "this is not an image\n";
  ExpectInputError([&] { ReadImageMetadata(dir / "text.jpg"); }, {"text.jpg"});
  ExpectInputError([&] { ReadImageMetadata(dir / "missing.jpg"); }, {"missing.jpg", "no such"});
  // A JPEG cut in the middle of its EXIF segment.
  {
    std::ifstream in(dir / "lat95.jpg", std::ios::binary);
    std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(dir / "cut.jpg", std::ios::binary).write(bytes.data(), 40);
  }
  ExpectInputError([&] { ReadImageMetadata(dir / "cut.jpg"); }, {"cut.jpg"});
  const std::uint8_t junk[] = {0xFF, 0xD8, 0xFF, 0xE1, 0xFF, 0xFF, 'E', 'x', 'i', 'f', 0, 0};
  ExpectInputError([&] { ParseImageMetadata(junk, sizeof(junk), "junk"); }, {"junk"});
  ExpectInputError([&] { ParseImageMetadata(nullptr, 0, "none"); }, {"none", "empty"});
}

// The EXIF size is used only when the decoder finds none (a JPEG without its frame header):
// a plausible value is taken, an absurd one (4000000000, which does not fit an int: the cast
// was undefined) leaves the size unknown instead.
TEST(ImageMetadata, ExifPixelDimensionsFallbackIsRangeChecked) {
  io_test::TempDir dir("aerovo_exif_dims");
  const auto headerless = [&](const std::string& x, const std::string& y) {
    const auto path = dir / "dims.jpg";
    io_test::WriteJpegWithTags(path, io_test::TextureImage(32, 24, 3),
                               {{"Exif.Photo.PixelXDimension", x},
                                {"Exif.Photo.PixelYDimension", y},
                                {"Exif.GPSInfo.GPSLatitude", "45/1 0/1 0/1"},
                                {"Exif.GPSInfo.GPSLatitudeRef", "N"},
                                {"Exif.GPSInfo.GPSLongitude", "10/1 0/1 0/1"},
                                {"Exif.GPSInfo.GPSLongitudeRef", "E"}});
    std::ifstream in(path, std::ios::binary);
    const std::vector<std::uint8_t> jpeg((std::istreambuf_iterator<char>(in)),
                                         std::istreambuf_iterator<char>());
    // SOI + the APP1 (EXIF) segment + EOI: no SOF, so Exiv2 knows no pixel size.
    std::size_t p = 2;
    while (p + 4 <= jpeg.size() && !(jpeg[p] == 0xFF && jpeg[p + 1] == 0xE1)) {
      p += 2 + (std::size_t{jpeg[p + 2]} << 8 | jpeg[p + 3]);
    }
    EXPECT_LT(p + 4, jpeg.size());
    const std::size_t len = 2 + (std::size_t{jpeg[p + 2]} << 8 | jpeg[p + 3]);
    std::vector<std::uint8_t> bytes = {0xFF, 0xD8};
    bytes.insert(bytes.end(), jpeg.begin() + p, jpeg.begin() + p + len);
    bytes.insert(bytes.end(), {0xFF, 0xD9});
    return ParseImageMetadata(bytes.data(), bytes.size(), "dims");
  };
  const ImageMetadata ok = headerless("4000", "3000");
  EXPECT_EQ(ok.width_px, 4000);
  EXPECT_EQ(ok.height_px, 3000);
  EXPECT_NEAR(*ok.lat_deg, 45.0, 1e-12);
  const ImageMetadata huge = headerless("4000000000", "2000000");
  EXPECT_EQ(huge.width_px, 0);
  EXPECT_EQ(huge.height_px, 0);
  EXPECT_NEAR(*huge.lat_deg, 45.0, 1e-12);  // the rest of the metadata is still read
}

// The hemisphere of a GPS coordinate is its reference tag's letter, and the side of sea level
// GPSAltitudeRef's 0 or 1 (EXIF 2.32, "GPS Attribute Information"). A reference that is missing
// or another letter was read as north / east: a photo at 33.87 S came out at 33.87 N. Now it
// is an error naming the photo and the tag; a coordinate of 0 needs none.
TEST(ImageMetadata, GpsReferencesGiveTheSignOrTheReadStops) {
  io_test::TempDir dir("aerovo_exif_refs");
  const auto img = io_test::TextureImage(32, 24, 4);
  const auto write = [&](const std::string& name, const std::string& lat_ref,
                         const std::string& lon_ref, const std::string& lat = "33/1 52/1 0/1") {
    std::map<std::string, std::string> tags = {{"Exif.GPSInfo.GPSLatitude", lat},
                                               {"Exif.GPSInfo.GPSLongitude", "151/1 12/1 36/1"}};
    if (!lat_ref.empty()) tags["Exif.GPSInfo.GPSLatitudeRef"] = lat_ref;
    if (!lon_ref.empty()) tags["Exif.GPSInfo.GPSLongitudeRef"] = lon_ref;
    io_test::WriteJpegWithTags(dir / name, img, tags);
    return dir / name;
  };
  const ImageMetadata sw = ReadImageMetadata(write("sw.jpg", "S", "W"));
  EXPECT_NEAR(*sw.lat_deg, -(33.0 + 52.0 / 60.0), 1e-12);
  EXPECT_NEAR(*sw.lon_deg, -(151.0 + 12.0 / 60.0 + 36.0 / 3600.0), 1e-12);
  ExpectInputError([&] { ReadImageMetadata(write("noref.jpg", "", "E")); },
                   {"noref.jpg: EXIF Exif.GPSInfo.GPSLatitude 33.8666667 has no "
                    "Exif.GPSInfo.GPSLatitudeRef ('N' or 'S' says the hemisphere"});
  ExpectInputError([&] { ReadImageMetadata(write("lower.jpg", "S", "w")); },
                   {"lower.jpg: EXIF Exif.GPSInfo.GPSLongitude 151.2100000 has "
                    "Exif.GPSInfo.GPSLongitudeRef 'w' ('E' or 'W'"});
  const ImageMetadata equator = ReadImageMetadata(write("equator.jpg", "", "E", "0/1 0/1 0/1"));
  EXPECT_EQ(*equator.lat_deg, 0.0);
  EXPECT_NEAR(*equator.lon_deg, 151.21, 1e-12);

  const auto altitude = [&](const std::string& name, const std::string& ref) {
    io_test::WriteJpegWithTags(dir / name, img,
                               {{"Exif.GPSInfo.GPSLatitude", "45/1 0/1 0/1"},
                                {"Exif.GPSInfo.GPSLatitudeRef", "N"},
                                {"Exif.GPSInfo.GPSLongitude", "10/1 0/1 0/1"},
                                {"Exif.GPSInfo.GPSLongitudeRef", "E"},
                                {"Exif.GPSInfo.GPSAltitude", "4305/10"},
                                {"Exif.GPSInfo.GPSAltitudeRef", ref}});
    return dir / name;
  };
  EXPECT_DOUBLE_EQ(*ReadImageMetadata(altitude("above.jpg", "0")).gps_alt_m, 430.5);
  EXPECT_DOUBLE_EQ(*ReadImageMetadata(altitude("below.jpg", "1")).gps_alt_m, -430.5);
  ExpectInputError([&] { ReadImageMetadata(altitude("ref3.jpg", "3")); },
                   {"ref3.jpg: EXIF GPSAltitudeRef 3 is neither 0 (above sea level) nor 1"});
}

TEST(ImageMetadata, TelemetryFromImagesOrderAndMissingGps) {
  ImageMetadata a, b, c, d;
  a.source = "a.jpg";
  a.lat_deg = 10.0;
  a.lon_deg = 20.0;
  a.capture_unix_time_s = 1000.0;
  b = a;
  b.source = "b.jpg";
  b.lat_deg.reset();
  b.lon_deg.reset();
  b.capture_unix_time_s = 1002.0;
  c = a;
  c.source = "c.jpg";
  c.lat_deg = 10.5;
  c.capture_unix_time_s = 1004.0;
  d = a;
  d.source = "d.jpg";
  d.capture_unix_time_s = 1003.0;  // earlier than c
  {
    const TelemetryReadResult r = TelemetryFromImages({a, b, c});
    ASSERT_EQ(r.records, 2);
    EXPECT_EQ(r.no_fix_records, 1);
    EXPECT_EQ(r.telemetry[1].frame_index, 2);
    EXPECT_DOUBLE_EQ(r.telemetry[1].time_s, 4.0);
    auto mid = r.telemetry.AtFrame(1);  // the photo without GPS, interpolated
    ASSERT_TRUE(mid);
    EXPECT_NEAR(mid->lat_deg, 10.25, 1e-12);
  }
  ExpectInputError([&] { TelemetryFromImages({a, c, d}); }, {"d.jpg", "out of order"});
  TelemetryReadOptions lenient;
  lenient.lenient = true;
  EXPECT_EQ(TelemetryFromImages({a, c, d}, lenient).skipped_records, 1);
  b.capture_unix_time_s.reset();
  b.lat_deg = 1.0;
  b.lon_deg = 2.0;
  const TelemetryReadResult ranks = TelemetryFromImages({a, b});
  EXPECT_DOUBLE_EQ(ranks.telemetry[1].time_s, 1.0);
  ASSERT_EQ(ranks.warnings.size(), 1u);
  ExpectInputError([&] { TelemetryFromImages({}); }, {"no telemetry samples"});
  // Messages name the photo, or the folder the photos are in (not "image metadata").
  a.source = "flight/a.jpg";
  b.source = "flight/b.jpg";
  EXPECT_THAT(TelemetryFromImages({a, b}).warnings[0],
              HasSubstr("flight: not every photo has a capture time"));
  b.lat_deg.reset();
  b.lon_deg.reset();
  ExpectInputError([&] { TelemetryFromImages({b}); },
                   {"flight/b.jpg: no telemetry samples", "1 without GPS fix"});
}

// Photos taken within one second by a camera that writes no SubSecTimeOriginal share their
// capture time: spread evenly within the second, in the telemetry and in PhotoTimes (the frame
// times of a photo folder) alike.
TEST(ImageMetadata, PhotosSharingACaptureTimeAreSpreadWithinItsResolution) {
  std::vector<ImageMetadata> photos(5);
  const double t[] = {1000, 1000, 1000, 1001, 1003};
  for (std::size_t i = 0; i < photos.size(); ++i) {
    photos[i].source = fmt::format("DJI_{:04d}.JPG", i);
    photos[i].lat_deg = 45.0;
    photos[i].lon_deg = 7.0 + 1e-5 * static_cast<double>(i);
    photos[i].capture_unix_time_s = t[i];
  }
  const std::vector<double> expected = {0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0, 3.0};
  const std::vector<double> times = PhotoTimes(photos);
  ASSERT_EQ(times.size(), 5u);
  const TelemetryReadResult r = TelemetryFromImages(photos);
  ASSERT_EQ(r.records, 5);
  for (std::size_t i = 0; i < 5; ++i) {
    EXPECT_NEAR(times[i], expected[i], 1e-12) << i;
    EXPECT_NEAR(r.telemetry[i].time_s, expected[i], 1e-12) << i;
    EXPECT_EQ(r.telemetry[i].frame_index, static_cast<int>(i));
  }
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_THAT(r.warnings[0], HasSubstr("3 photos share their capture time with another"));
  EXPECT_THAT(r.warnings[0], HasSubstr("'DJI_0000.JPG'"));

  // With SubSecTimeOriginal (two digits: 0.01 s) the run lies within that hundredth.
  photos[1].capture_time_resolution_s = 0.01;
  photos[0].capture_time_resolution_s = 0.01;
  photos[2].capture_time_resolution_s = 0.01;
  const std::vector<double> fine = PhotoTimes(photos);
  EXPECT_NEAR(fine[1], 0.01 / 3.0, 1e-12);
  EXPECT_NEAR(fine[2], 0.02 / 3.0, 1e-12);
  // One capture time for all: a second for the run (the resolution), never one time per frame.
  for (ImageMetadata& m : photos) {
    m.capture_unix_time_s = 1000.0;
    m.capture_time_resolution_s = 1.0;
  }
  const std::vector<double> same = PhotoTimes(photos);
  EXPECT_NEAR(same[4], 0.8, 1e-12);
}

}  // namespace
}  // namespace aerovo::image_metadata_test
