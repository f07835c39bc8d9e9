// Test helpers of the frames module (used by *_test.cc only): random-texture images and JPEGs
// with EXIF/XMP tags written through Exiv2. Temporary folders and InputError checks:
// telemetry/io_test_util.h.
#pragma once

#include <filesystem>
#include <fstream>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
#include <exiv2/exiv2.hpp>

namespace aerovo::io_test {

/// Random-texture BGR image (deterministic for a seed).
inline cv::Mat TextureImage(int width, int height, unsigned seed) {
  cv::Mat m(height, width, CV_8UC3);
  cv::RNG rng(seed);
  rng.fill(m, cv::RNG::UNIFORM, 0, 256);
  return m;
}

/// Writes `image` as a JPEG at `path`, then sets the given EXIF tags (key -> value text in
/// Exiv2's notation, e.g. {"Exif.GPSInfo.GPSLatitude", "43/1 30/1 0/1"}) and XMP tags.
inline void WriteJpegWithTags(const std::filesystem::path& path, const cv::Mat& image,
                              const std::map<std::string, std::string>& exif_tags,
                              const std::map<std::string, std::string>& xmp_tags = {}) {
  cv::imwrite(path.string(), image);
  auto img = Exiv2::ImageFactory::open(path.string());
  img->readMetadata();
  Exiv2::ExifData exif = img->exifData();
  for (const auto& [k, v] : exif_tags) exif[k] = v;
  img->setExifData(exif);
  if (!xmp_tags.empty()) {
    Exiv2::XmpProperties::registerNs("http://www.dji.com/drone-dji/1.0/", "drone-dji");
    Exiv2::XmpData xmp = img->xmpData();
    for (const auto& [k, v] : xmp_tags) xmp[k] = v;
    img->setXmpData(xmp);
  }
  img->writeMetadata();
}

/// Writes `image` as a JPEG at `path` with `xmp_packet` as its XMP, byte for byte: an APP1
/// segment "http://ns.adobe.com/xap/1.0/\0" + packet (XMP specification part 3, 1.1.3) right
/// after the start-of-image marker. The packet must fit one segment (65502 bytes).
inline void WriteJpegWithXmpPacket(const std::filesystem::path& path, const cv::Mat& image,
                                   const std::string& xmp_packet) {
  std::vector<unsigned char> jpeg;
  cv::imencode(".jpg", image, jpeg);
  const std::string header("http://ns.adobe.com/xap/1.0/\0", 29);
  const std::size_t length = 2 + header.size() + xmp_packet.size();
  if (length > 0xFFFF) throw std::length_error("XMP packet too long for one APP1 segment");
  std::string app1 = {'\xFF', '\xE1', static_cast<char>(length >> 8),
                      static_cast<char>(length & 0xFF)};
  app1 += header + xmp_packet;
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(jpeg.data()), 2);  // SOI
  out << app1;
  out.write(reinterpret_cast<const char*>(jpeg.data()) + 2,
            static_cast<std::streamsize>(jpeg.size() - 2));
}

/// Adds the given EXIF tags (as WriteJpegWithTags) to the image file at `path` and, when
/// `xmp_packet` is given, sets it as the file's XMP; the XMP packet is written byte for byte.
inline void AddExifTags(const std::filesystem::path& path,
                        const std::map<std::string, std::string>& exif_tags,
                        const std::string* xmp_packet = nullptr) {
  auto img = Exiv2::ImageFactory::open(path.string());
  img->readMetadata();
  Exiv2::ExifData exif = img->exifData();
  for (const auto& [k, v] : exif_tags) exif[k] = v;
  img->setExifData(exif);
  if (xmp_packet != nullptr) img->setXmpPacket(*xmp_packet);
  img->writeXmpFromPacket(true);
  img->writeMetadata();
}

/// Writes `image` (8 or 16 bits per sample) as a TIFF at `path` with `exif_tags` (Exiv2 keys,
/// as WriteJpegWithTags) and `xmp_packet` byte for byte in its XMP tag 700 (0x02bc, where
/// TIFF-writing cameras such as MicaSense's and DJI P4 Multispectral's bands keep it).
inline void WriteTiffWithXmpPacket(const std::filesystem::path& path, const cv::Mat& image,
                                   const std::map<std::string, std::string>& exif_tags,
                                   const std::string& xmp_packet) {
  if (!cv::imwrite(path.string(), image)) throw std::runtime_error("cannot write " + path.string());
  AddExifTags(path, exif_tags, &xmp_packet);
}

/// The XMP packet of a MicaSense RedEdge-MX band TIFF (its tag 700), as the camera writes it:
/// one rdf:Description per namespace (MicaSense, Camera, DLS), the Camera namespace without its
/// final slash; the radiometric and lens tags shortened.
inline std::string MicaSenseBandPacket(const std::string& capture, const std::string& band,
                                       const std::string& rig_index) {
  return std::string("<?xpacket begin=\"\xEF\xBB\xBF\" id=\"W5M0MpCehiHzreSzNTczkc9d\"?>\n") +
         "<x:xmpmeta xmlns:x=\"adobe:ns:meta/\" x:xmptk=\"XMP Core 4.4.0\">\n"
         "   <rdf:RDF xmlns:rdf=\"http://www.w3.org/1999/02/22-rdf-syntax-ns#\">\n"
         "      <rdf:Description rdf:about=\"Pix4D Camera Information\"\n"
         "            xmlns:MicaSense=\"http://micasense.com/MicaSense/1.0/\">\n"
         "         <MicaSense:BootTimestamp>466</MicaSense:BootTimestamp>\n"
         "         <MicaSense:RadiometricCalibration>\n            <rdf:Seq>\n"
         "               <rdf:li>0.000145914</rdf:li>\n"
         "               <rdf:li>1.39479e-07</rdf:li>\n"
         "            </rdf:Seq>\n         </MicaSense:RadiometricCalibration>\n"
         "         <MicaSense:FlightId>20Ntb9oCOg7Cm7HUbb1i</MicaSense:FlightId>\n"
         "         <MicaSense:CaptureId>" +
         capture +
         "</MicaSense:CaptureId>\n"
         "         <MicaSense:TriggerMethod>4</MicaSense:TriggerMethod>\n"
         "      </rdf:Description>\n"
         "      <rdf:Description rdf:about=\"Pix4D Camera Information\"\n"
         "            xmlns:Camera=\"http://pix4d.com/camera/1.0\">\n"
         "         <Camera:BandName>" +
         band +
         "</Camera:BandName>\n"
         "         <Camera:CentralWavelength>475</Camera:CentralWavelength>\n"
         "         <Camera:RigCameraIndex>" +
         rig_index +
         "</Camera:RigCameraIndex>\n"
         "      </rdf:Description>\n"
         "      <rdf:Description rdf:about=\"Pix4D Camera Information\"\n"
         "            xmlns:DLS=\"http://micasense.com/DLS/1.0/\">\n"
         "         <DLS:SensorId>0</DLS:SensorId>\n"
         "         <DLS:Yaw>0.73310724098153246</DLS:Yaw>\n"
         "      </rdf:Description>\n"
         "   </rdf:RDF>\n</x:xmpmeta>\n<?xpacket end=\"w\"?>";
}

}  // namespace aerovo::io_test

#pragma GCC diagnostic pop
