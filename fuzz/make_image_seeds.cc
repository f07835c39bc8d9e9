// Writes the seed corpus of fuzz_image_metadata (fuzz/corpus/image_metadata/): tiny JPEG/PNG
// files with EXIF GPS and DJI XMP tags, valid and invalid. Not part of the build; rerun with
//   g++ -std=c++17 fuzz/make_image_seeds.cc -o /tmp/make_image_seeds \
//     $(pkg-config --cflags --libs exiv2 opencv4) && /tmp/make_image_seeds
//     fuzz/corpus/image_metadata
// Not written here (Exiv2 drops tag 0x02bc from a JPEG): xt2_exif_ifd_packet.jpg (a DJI XT2
// photo's layout: the XMP packet in tag 0x02bc of the Exif sub-IFD, GPS with an altitude above
// sea level) and ifd0_xml_packet.jpg (the packet in IFD0's XMLPacket), written with
// io_test::WriteJpegWithExif (src/aerovo/frames/exif_test_writer.h) as in
// ImageMetadata.XmpPacketInTheExifSubIfdApplicationNotes. Nor micasense_band.tif (an 8x8 16-bit
// TIFF with a MicaSense band's XMP in tag 700: MicaSense:CaptureId, Camera:BandName "Red edge",
// Camera:RigCameraIndex 4) and dji_thermal_image_source.jpg (drone-dji:ImageSource
// "InfraredCamera", CaptureUUID), written with io_test::WriteTiffWithXmpPacket and
// WriteJpegWithXmpPacket (src/aerovo/frames/image_test_util.h) as in
// ImageMetadataVendors.MicaSenseBandTiffNamesItsBandAndCapture.
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
#include <exiv2/exiv2.hpp>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <string>
int main(int argc, char** argv) {
  const std::string dir = argv[1];
  Exiv2::XmpParser::initialize();
  Exiv2::XmpProperties::registerNs("http://www.dji.com/drone-dji/1.0/", "drone-dji");
  cv::Mat img(8, 8, CV_8UC3, cv::Scalar(40, 120, 200));
  auto write = [&](const std::string& name, const std::map<std::string, std::string>& exif_tags,
                   const std::map<std::string, std::string>& xmp_tags) {
    const std::string path = dir + "/" + name;
    cv::imwrite(path, img, {cv::IMWRITE_JPEG_QUALITY, 10});
    auto im = Exiv2::ImageFactory::open(path);
    im->readMetadata();
    Exiv2::ExifData exif;
    for (const auto& [k, v] : exif_tags) exif[k] = v;
    im->setExifData(exif);
    Exiv2::XmpData xmp;
    for (const auto& [k, v] : xmp_tags) xmp[k] = v;
    im->setXmpData(xmp);
    im->writeMetadata();
  };
  write("dji_gps_xmp.jpg",
        {{"Exif.Image.Make", "DJI"},
         {"Exif.Image.Model", "FC6310"},
         {"Exif.GPSInfo.GPSLatitude", "43/1 32/1 1212/100"},
         {"Exif.GPSInfo.GPSLatitudeRef", "N"},
         {"Exif.GPSInfo.GPSLongitude", "6/1 33/1 2412/100"},
         {"Exif.GPSInfo.GPSLongitudeRef", "W"},
         {"Exif.GPSInfo.GPSAltitude", "35012/100"},
         {"Exif.GPSInfo.GPSAltitudeRef", "1"},
         {"Exif.Photo.DateTimeOriginal", "2023:05:01 12:00:00"},
         {"Exif.Photo.SubSecTimeOriginal", "25"},
         {"Exif.Photo.FocalLength", "88/10"},
         {"Exif.Photo.FocalLengthIn35mmFilm", "24"},
         {"Exif.Photo.PixelXDimension", "8"},
         {"Exif.Photo.PixelYDimension", "8"}},
        {{"Xmp.drone-dji.RelativeAltitude", "+80.25"},
         {"Xmp.drone-dji.AbsoluteAltitude", "+350.1"},
         {"Xmp.drone-dji.FlightYawDegree", "-45.5"},
         {"Xmp.drone-dji.FlightPitchDegree", "1.2"},
         {"Xmp.drone-dji.FlightRollDegree", "0.3"},
         {"Xmp.drone-dji.GimbalYawDegree", "-45.5"},
         {"Xmp.drone-dji.GimbalPitchDegree", "-90.0"},
         {"Xmp.drone-dji.GimbalRollDegree", "0"},
         {"Xmp.drone-dji.CalibratedFocalLength", "3666.67"},
         {"Xmp.drone-dji.CalibratedOpticalCenterX", "2736"},
         {"Xmp.drone-dji.CalibratedOpticalCenterY", "1824"}});
  write("zero_denominator.jpg",
        {{"Exif.GPSInfo.GPSLatitude", "33/0 1/1 0/1"},
         {"Exif.GPSInfo.GPSLongitude", "1/1 0/0 0/0"},
         {"Exif.Photo.FocalLength", "0/0"}},
        {});
  write("out_of_range.jpg",
        {{"Exif.GPSInfo.GPSLatitude", "95/1 0/1 0/1"},
         {"Exif.GPSInfo.GPSLongitude", "1/1 0/1"},
         {"Exif.Photo.DateTimeOriginal", "    :  :     :  :  "}},
        {{"Xmp.drone-dji.GimbalYawDegree", "720"}});
  write("xmp_not_a_number.jpg", {{"Exif.GPSInfo.GPSLatitude", "1/1 2/1 3/1"}},
        {{"Xmp.drone-dji.RelativeAltitude", "abc"}});
  cv::imwrite(dir + "/no_metadata.png", img);
  // A truncated file: the first 160 bytes of the full one.
  std::ifstream in(dir + "/dji_gps_xmp.jpg", std::ios::binary);
  std::string head(160, '\0');
  in.read(head.data(), head.size());
  std::ofstream(dir + "/truncated.jpg", std::ios::binary).write(head.data(), in.gcount());
}
