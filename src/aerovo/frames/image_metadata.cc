#include "aerovo/frames/image_metadata.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <mutex>
#include <string_view>
#include <utility>
#include <vector>

#include <fmt/format.h>

// Exiv2 0.27's API hands out std::auto_ptr (deprecated in C++11, still shipped by libstdc++);
// the warnings come from its headers and its return types, not from anything we can change.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
#include <exiv2/exiv2.hpp>

#include "aerovo/core/error.h"
#include "aerovo/telemetry/parse_util.h"

namespace aerovo {
namespace {

void InitExiv2Once() {
  static std::once_flag once;
  std::call_once(once, [] {
    // Exiv2 prints warnings about odd-but-harmless maker notes to stderr; problems that matter
    // surface as exceptions or as missing/invalid values we check ourselves.
    Exiv2::LogMsg::setLevel(Exiv2::LogMsg::mute);
    Exiv2::XmpParser::initialize();
    // Looking up "Xmp.drone-dji.*" keys needs the prefix known even for files without DJI XMP.
    Exiv2::XmpProperties::registerNs("http://www.dji.com/drone-dji/1.0/", "drone-dji");
    // The other vendors' namespaces (kVendors below). Exiv2 names a decoded property by the
    // prefix registered for its namespace URI, whatever prefix the file declares, so that
    // "Xmp.Camera.Pitch" is Pix4D's tag in every photo and senseFly's tag of the same name
    // (another URI, also written with the prefix "Camera") is "Xmp.senseFly-Camera.Pitch".
    Exiv2::XmpProperties::registerNs("http://www.parrot.com/drone-parrot/1.0/", "drone-parrot");
    Exiv2::XmpProperties::registerNs("http://pix4d.com/camera/1.0/", "Camera");
    Exiv2::XmpProperties::registerNs("http://ns.sensefly.com/Camera/1.0/", "senseFly-Camera");
    // MicaSense's own namespace (MicaSense:CaptureId of a rig's capture).
    Exiv2::XmpProperties::registerNs("http://micasense.com/MicaSense/1.0/", "MicaSense");
  });
}

// Message of an exception thrown while Exiv2 reads a file. Besides Exiv2::AnyError, Exiv2 0.27
// lets standard exceptions out on corrupt files (std::overflow_error from its Safe:: arithmetic,
// std::out_of_range, std::bad_alloc for absurd sizes): all mean "this file cannot be read".
std::string ExivWhat(const std::exception& e) {
  if (dynamic_cast<const Exiv2::AnyError*>(&e) != nullptr) return e.what();
  return fmt::format("corrupt metadata ({})", e.what());
}

std::optional<std::string> ExifString(const Exiv2::ExifData& exif, const char* key) {
  const auto it = exif.findKey(Exiv2::ExifKey(key));
  if (it == exif.end() || it->count() == 0) return std::nullopt;
  return it->toString();
}

// A single rational/short/long EXIF value as a double; throws on a zero denominator.
std::optional<double> ExifNumber(const Exiv2::ExifData& exif, const char* key,
                                 const std::string& source) {
  const auto it = exif.findKey(Exiv2::ExifKey(key));
  if (it == exif.end() || it->count() == 0) return std::nullopt;
  const Exiv2::TypeId type = it->typeId();
  if (type == Exiv2::unsignedRational || type == Exiv2::signedRational) {
    const Exiv2::Rational r = it->toRational(0);
    if (r.second == 0) {
      if (r.first == 0) return std::nullopt;  // 0/0: cameras write it for "unknown"
      throw InputError(fmt::format("{}: EXIF {} has a zero denominator", source, key));
    }
    return static_cast<double>(r.first) / static_cast<double>(r.second);
  }
  if (type == Exiv2::unsignedShort || type == Exiv2::unsignedLong || type == Exiv2::signedShort ||
      type == Exiv2::signedLong || type == Exiv2::unsignedByte) {
    return static_cast<double>(it->toLong(0));
  }
  return ParseDecimal(it->toString());
}

// Degrees/minutes/seconds rational triple with its hemisphere reference: GPSLatitudeRef 'N'
// or 'S', GPSLongitudeRef 'E' or 'W' (EXIF 2.32, CIPA DC-008-2019, "GPS Attribute
// Information"). The reference alone gives the sign: a position off the equator or the prime
// meridian whose reference is missing or another letter is an InputError naming the photo and
// the tag (read as positive before, a flight south of the equator was put north of it).
std::optional<double> ExifDms(const Exiv2::ExifData& exif, const char* key, const char* ref_key,
                              const char* positive_ref, const char* negative_ref,
                              const std::string& source) {
  const auto it = exif.findKey(Exiv2::ExifKey(key));
  if (it == exif.end()) return std::nullopt;
  if (it->count() != 3) {
    throw InputError(
        fmt::format("{}: EXIF {} has {} components (expected 3)", source, key, it->count()));
  }
  double parts[3];
  for (long i = 0; i < 3; ++i) {
    const Exiv2::Rational r = it->toRational(i);
    if (r.second == 0) {
      if (r.first == 0 && i > 0) {  // 0/0 minutes or seconds: some writers mean "0"
        parts[i] = 0.0;
        continue;
      }
      throw InputError(fmt::format("{}: EXIF {} has a zero denominator", source, key));
    }
    parts[i] = static_cast<double>(r.first) / static_cast<double>(r.second);
    if (parts[i] < 0.0) {
      throw InputError(fmt::format("{}: EXIF {} has a negative component", source, key));
    }
  }
  double deg = parts[0] + parts[1] / 60.0 + parts[2] / 3600.0;
  const std::string ref(TrimSpace(ExifString(exif, ref_key).value_or("")));
  if (ref == negative_ref) return -deg;
  if (ref != positive_ref && deg != 0.0) {
    throw InputError(
        fmt::format("{}: EXIF {} {:.7f} has {} ('{}' or '{}' says the hemisphere, EXIF 2.32): "
                    "its sign cannot be told",
                    source, key, deg,
                    ref.empty() ? fmt::format("no {}", ref_key)
                                : fmt::format("{} '{}'", ref_key, Printable(ref, 20)),
                    positive_ref, negative_ref));
  }
  return deg;
}

std::optional<double> XmpNumber(const Exiv2::XmpData& xmp, const char* key,
                                const std::string& source) {
  const auto it = xmp.findKey(Exiv2::XmpKey(key));
  if (it == xmp.end()) return std::nullopt;
  const std::string text = it->toString();
  const auto v = ParseDecimal(text);
  if (!v) {
    throw InputError(fmt::format("{}: XMP {} '{}' is not a number", source, key,
                                 std::string_view(text).substr(0, 40)));
  }
  return v;
}

void CheckRange(const std::optional<double>& v, double lo, double hi, const char* what,
                const std::string& source) {
  if (v && (!std::isfinite(*v) || *v < lo || *v > hi)) {
    throw InputError(fmt::format("{}: {} {} out of range [{}, {}]", source, what, *v, lo, hi));
  }
}

// An XMP Real or Rational (XMP specification part 1, 8.2.1: a Rational is written
// "numerator/denominator"; Parrot writes its heights so, e.g. "11485529/262144") as a double.
// Throws InputError naming the file and the tag (`what`) for text that is neither, and for a
// zero denominator.
std::optional<double> XmpRealOrRational(const Exiv2::XmpData& xmp, const std::string& key,
                                        const std::string& what, const std::string& source) {
  const auto it = xmp.findKey(Exiv2::XmpKey(key));
  if (it == xmp.end()) return std::nullopt;
  const std::string text = it->toString();
  const std::string_view t = TrimSpace(text);
  std::optional<double> v;
  if (const auto slash = t.find('/'); slash == std::string_view::npos) {
    v = ParseDecimal(t);
  } else {
    const auto num = ParseDecimal(t.substr(0, slash));
    const auto den = ParseDecimal(t.substr(slash + 1));
    if (num && den && *den == 0.0) {
      throw InputError(
          fmt::format("{}: XMP {} '{}' has a zero denominator", source, what, Printable(t, 40)));
    }
    if (num && den) v = *num / *den;
  }
  if (!v) {
    throw InputError(
        fmt::format("{}: XMP {} '{}' is not a number", source, what, Printable(t, 40)));
  }
  return v;
}

// The XMP packet some cameras store in the EXIF tag 0x02bc instead of an APP1 XMP segment:
// in IFD0 (XMLPacket, TIFF/EP; DJI Zenmuse XT/H20T, some Autel cameras) or in the Exif sub-IFD
// (exiftool's ExifIFD:ApplicationNotes; DJI Zenmuse XT2), of type BYTE or UNDEFINED. Decoded
// into `*out`; false when the tag is absent or holds only blanks and NULs. A packet that does
// not parse is an error naming the file and the tag (it is the camera's metadata, not
// something to ignore silently).
bool XmpFromExifPacket(const Exiv2::ExifData& exif, const Exiv2::ExifKey& key, const char* what,
                       const std::string& source, Exiv2::XmpData* out) {
  const auto it = exif.findKey(key);
  if (it == exif.end() || it->size() == 0) return false;
  std::string packet(static_cast<std::size_t>(it->size()), '\0');
  it->copy(reinterpret_cast<Exiv2::byte*>(packet.data()), Exiv2::invalidByteOrder);
  while (!packet.empty() && packet.back() == '\0') packet.pop_back();
  if (packet.find_first_not_of(" \t\r\n") == std::string::npos) return false;
  if (Exiv2::XmpParser::decode(*out, packet) != 0) {
    throw InputError(
        fmt::format("{}: the XMP packet in EXIF tag 0x02bc ({}, {} bytes) does not parse", source,
                    what, packet.size()));
  }
  return !out->empty();
}

bool HasDjiXmp(const Exiv2::XmpData& xmp) {
  for (const auto& d : xmp) {
    if (d.groupName() == "drone-dji") return true;
  }
  return false;
}

// EXIF Make, Model and serial number (EXIF BodySerialNumber, CameraSerialNumber, else DJI XMP).
void ReadCameraIdentity(const Exiv2::ExifData& exif, const Exiv2::XmpData& xmp, ImageMetadata& m) {
  m.make = std::string(TrimSpace(ExifString(exif, "Exif.Image.Make").value_or("")));
  m.model = std::string(TrimSpace(ExifString(exif, "Exif.Image.Model").value_or("")));
  for (const char* key : {"Exif.Photo.BodySerialNumber", "Exif.Image.CameraSerialNumber"}) {
    if (m.serial_number.empty()) {
      m.serial_number = std::string(TrimSpace(ExifString(exif, key).value_or("")));
    }
  }
  if (m.serial_number.empty()) {
    // DJI writes the camera's serial number in its XMP (drone-dji:CameraSerialNumber).
    const auto it = xmp.findKey(Exiv2::XmpKey("Xmp.drone-dji.CameraSerialNumber"));
    if (it != xmp.end()) m.serial_number = std::string(TrimSpace(it->toString()));
  }
}

// EXIF GPS position and altitude; InputError for a value out of range or half a position.
void ReadExifGps(const Exiv2::ExifData& exif, const std::string& source, ImageMetadata& m) {
  m.lat_deg =
      ExifDms(exif, "Exif.GPSInfo.GPSLatitude", "Exif.GPSInfo.GPSLatitudeRef", "N", "S", source);
  m.lon_deg =
      ExifDms(exif, "Exif.GPSInfo.GPSLongitude", "Exif.GPSInfo.GPSLongitudeRef", "E", "W", source);
  CheckRange(m.lat_deg, -90.0, 90.0, "EXIF GPS latitude", source);
  CheckRange(m.lon_deg, -180.0, 180.0, "EXIF GPS longitude", source);
  if (m.lat_deg.has_value() != m.lon_deg.has_value()) {
    throw InputError(fmt::format("{}: EXIF GPS has a {} but no {}", source,
                                 m.lat_deg ? "latitude" : "longitude",
                                 m.lat_deg ? "longitude" : "latitude"));
  }
  m.gps_alt_m = ExifNumber(exif, "Exif.GPSInfo.GPSAltitude", source);
  if (m.gps_alt_m) {
    // GPSAltitudeRef: 0 above sea level, 1 below (the altitude then its absolute value); absent
    // means 0 (EXIF 2.32, "GPS Attribute Information"). Any other value is not read as either.
    const auto ref = ExifNumber(exif, "Exif.GPSInfo.GPSAltitudeRef", source);
    if (ref && *ref != 0.0 && *ref != 1.0) {
      throw InputError(fmt::format(
          "{}: EXIF GPSAltitudeRef {} is neither 0 (above sea level) nor 1 (below sea level; "
          "EXIF 2.32): the altitude's sign cannot be told",
          source, *ref));
    }
    if (ref && *ref == 1.0) m.gps_alt_m = -*m.gps_alt_m;
  }
  CheckRange(m.gps_alt_m, -1e5, 1e5, "EXIF GPS altitude", source);
}

// EXIF DateTimeOriginal + SubSecTimeOriginal as seconds since 1970 (read as UTC).
void ReadCaptureTime(const Exiv2::ExifData& exif, ImageMetadata& m) {
  if (auto dt = ExifString(exif, "Exif.Photo.DateTimeOriginal")) {
    m.capture_unix_time_s = io_detail::ParseDateTime(*dt);
    if (m.capture_unix_time_s) {
      if (auto sub = ExifString(exif, "Exif.Photo.SubSecTimeOriginal")) {
        // SubSecTime holds the digits of the fraction: "123" = 0.123 s, "5" = 0.5 s.
        const std::string_view digits = TrimSpace(*sub);
        double frac = 0.0, scale = 0.1;
        bool ok = !digits.empty() && digits.size() <= 9;
        for (char c : digits) {
          if (c < '0' || c > '9') ok = false;
          frac += (c - '0') * scale;
          scale *= 0.1;
        }
        if (ok) {
          *m.capture_unix_time_s += frac;
          m.capture_time_resolution_s = scale * 10.0;
        }
      }
    }
  }
}

// DJI XMP (drone-dji): heights, flight and gimbal attitude, calibrated focal length and centre;
// InputError for a value out of range.
void ReadDjiXmp(const Exiv2::XmpData& xmp, const std::string& source, ImageMetadata& m) {
  m.rel_alt_m = XmpNumber(xmp, "Xmp.drone-dji.RelativeAltitude", source);
  m.abs_alt_m = XmpNumber(xmp, "Xmp.drone-dji.AbsoluteAltitude", source);
  m.flight_yaw_deg = XmpNumber(xmp, "Xmp.drone-dji.FlightYawDegree", source);
  m.flight_pitch_deg = XmpNumber(xmp, "Xmp.drone-dji.FlightPitchDegree", source);
  m.flight_roll_deg = XmpNumber(xmp, "Xmp.drone-dji.FlightRollDegree", source);
  m.gimbal_yaw_deg = XmpNumber(xmp, "Xmp.drone-dji.GimbalYawDegree", source);
  m.gimbal_pitch_deg = XmpNumber(xmp, "Xmp.drone-dji.GimbalPitchDegree", source);
  m.gimbal_roll_deg = XmpNumber(xmp, "Xmp.drone-dji.GimbalRollDegree", source);
  m.calibrated_focal_px = XmpNumber(xmp, "Xmp.drone-dji.CalibratedFocalLength", source);
  m.calibrated_cx_px = XmpNumber(xmp, "Xmp.drone-dji.CalibratedOpticalCenterX", source);
  m.calibrated_cy_px = XmpNumber(xmp, "Xmp.drone-dji.CalibratedOpticalCenterY", source);
  CheckRange(m.rel_alt_m, -1e5, 1e5, "XMP RelativeAltitude", source);
  CheckRange(m.abs_alt_m, -1e5, 1e5, "XMP AbsoluteAltitude", source);
  for (auto [v, what] : {std::pair{&m.flight_yaw_deg, "XMP FlightYawDegree"},
                         {&m.flight_pitch_deg, "XMP FlightPitchDegree"},
                         {&m.flight_roll_deg, "XMP FlightRollDegree"},
                         {&m.gimbal_yaw_deg, "XMP GimbalYawDegree"},
                         {&m.gimbal_pitch_deg, "XMP GimbalPitchDegree"},
                         {&m.gimbal_roll_deg, "XMP GimbalRollDegree"}}) {
    CheckRange(*v, -360.0, 360.0, what, source);
  }
  CheckRange(m.calibrated_focal_px, 1e-3, 1e7, "XMP CalibratedFocalLength (px)", source);
}

// The XMP flight values of the other vendors (docs/inputs.md, "XMP of other vendors"), each
// read into an ImageMetadata field in DJI's convention.
//
// How a written value becomes DJI's convention (degrees; yaw clockwise from north; gimbal pitch
// -90 = nadir, 0 = horizon; heights in metres):
enum class Conv {
  kAsWritten,
  // Pix4D's camera pitch: 0 = nadir, 90 = looking forward (Pix4D, "Yaw, Pitch, Roll and Omega,
  // Phi, Kappa angles", support.pix4d.com/hc/en-us/articles/202558969): DJI's pitch + 90. Its
  // yaw (the heading of the image top when nadir) and roll (positive: right wing down, the
  // optical axis towards the image left) are DJI's gimbal yaw and roll. Parrot's documentation
  // shows the two conventions on one photo: Camera:Pitch "38.011101" beside
  // drone-parrot:CameraPitchDegree "-51.988888".
  kPix4dPitch,
};

struct VendorTag {
  const char* key;   // Exiv2 key, with the prefix registered in InitExiv2Once
  const char* name;  // the tag as the vendor documents it, for messages
  std::optional<double> ImageMetadata::*field;
  Conv conv;
  double lo, hi;  // accepted range of the written value (as the DJI fields')
};

struct VendorXmp {
  ImageMetadata::XmpVendor vendor;
  // The photo is this vendor's when it has one of the tags in this namespace prefix (Parrot's
  // photos also carry Pix4D's Camera tags; its own drone-parrot angles are read first).
  const char* own_prefix;
  std::vector<VendorTag> tags;
};

constexpr double kMaxHeightM = 1e5;
constexpr double kMaxAngleDeg = 360.0;

const std::vector<VendorXmp>& Vendors() {
  using M = ImageMetadata;
  using V = ImageMetadata::XmpVendor;
  // Pix4D's "Specifications of XMP Camera tags" (support.pix4d.com/hc/en-us/articles/
  // 360016450032): namespace Camera, http://pix4d.com/camera/1.0/, Yaw/Pitch/Roll of the camera
  // in degrees; AboveGroundAltitude as Parrot documents it (height above the ground, metres).
  static const std::vector<VendorXmp> vendors = {
      // Parrot, "Embedded Photo Metadata" (developer.parrot.com/docs/groundsdk-tools/
      // photo-metadata.html): drone-parrot:Camera{Roll,Pitch,Yaw}Degree, the camera's
      // orientation in degrees in NED (pitch -90 = nadir, as DJI's), and the Pix4D
      // Camera:AboveGroundAltitude, "altitude above the ground in meters expressed as a
      // fraction". Namespace http://www.parrot.com/drone-parrot/1.0/.
      {V::kParrot,
       "drone-parrot",
       {{"Xmp.drone-parrot.CameraYawDegree", "drone-parrot:CameraYawDegree", &M::gimbal_yaw_deg,
         Conv::kAsWritten, -kMaxAngleDeg, kMaxAngleDeg},
        {"Xmp.drone-parrot.CameraPitchDegree", "drone-parrot:CameraPitchDegree",
         &M::gimbal_pitch_deg, Conv::kAsWritten, -kMaxAngleDeg, kMaxAngleDeg},
        {"Xmp.drone-parrot.CameraRollDegree", "drone-parrot:CameraRollDegree", &M::gimbal_roll_deg,
         Conv::kAsWritten, -kMaxAngleDeg, kMaxAngleDeg},
        {"Xmp.Camera.AboveGroundAltitude", "Camera:AboveGroundAltitude", &M::rel_alt_m,
         Conv::kAsWritten, -kMaxHeightM, kMaxHeightM}}},
      // Pix4D's Camera namespace alone (Parrot Sequoia, multispectral cameras, photos tagged
      // for Pix4D): the camera's angles in Pix4D's convention.
      {V::kPix4dCamera,
       "Camera",
       {{"Xmp.Camera.Yaw", "Camera:Yaw", &M::gimbal_yaw_deg, Conv::kAsWritten, -kMaxAngleDeg,
         kMaxAngleDeg},
        {"Xmp.Camera.Pitch", "Camera:Pitch", &M::gimbal_pitch_deg, Conv::kPix4dPitch, -kMaxAngleDeg,
         kMaxAngleDeg},
        {"Xmp.Camera.Roll", "Camera:Roll", &M::gimbal_roll_deg, Conv::kAsWritten, -kMaxAngleDeg,
         kMaxAngleDeg},
        {"Xmp.Camera.AboveGroundAltitude", "Camera:AboveGroundAltitude", &M::rel_alt_m,
         Conv::kAsWritten, -kMaxHeightM, kMaxHeightM}}},
      // senseFly (eBee S.O.D.A., Aeria): the same Yaw/Pitch/Roll tags under its own namespace
      // http://ns.sensefly.com/Camera/1.0/, in Pix4D's convention (pitch 0 = nadir): orthority's
      // "EXIF / XMP tags" (leftfield-geospatial/orthority docs/file_formats/exif_xmp.rst) reads
      // them as one tag set with Pix4D's; OpenMVS converts senseFly's pitch with "-90" (senseFly
      // "uses pitch 0 as NADIR, whereas DJI -90").
      {V::kSenseFlyCamera,
       "senseFly-Camera",
       {{"Xmp.senseFly-Camera.Yaw", "Camera:Yaw (senseFly)", &M::gimbal_yaw_deg, Conv::kAsWritten,
         -kMaxAngleDeg, kMaxAngleDeg},
        {"Xmp.senseFly-Camera.Pitch", "Camera:Pitch (senseFly)", &M::gimbal_pitch_deg,
         Conv::kPix4dPitch, -kMaxAngleDeg, kMaxAngleDeg},
        {"Xmp.senseFly-Camera.Roll", "Camera:Roll (senseFly)", &M::gimbal_roll_deg,
         Conv::kAsWritten, -kMaxAngleDeg, kMaxAngleDeg}}},
  };
  return vendors;
}

// True when `xmp` holds one of `v`'s tags in its own namespace.
bool HasVendorXmp(const Exiv2::XmpData& xmp, const VendorXmp& v) {
  const std::string own = std::string("Xmp.") + v.own_prefix + ".";
  for (const VendorTag& t : v.tags) {
    if (std::string_view(t.key).substr(0, own.size()) == own &&
        xmp.findKey(Exiv2::XmpKey(t.key)) != xmp.end()) {
      return true;
    }
  }
  return false;
}

bool HasOtherVendorXmp(const Exiv2::XmpData& xmp) {
  const auto& vs = Vendors();
  return std::any_of(vs.begin(), vs.end(),
                     [&](const VendorXmp& v) { return HasVendorXmp(xmp, v); });
}

// Reads the first vendor of Vendors() whose values `xmp` holds into `m` (converted to DJI's
// convention); InputError naming the file and the tag for a value that is not a number or out
// of range.
void ReadOtherVendorXmp(const Exiv2::XmpData& xmp, const std::string& source, ImageMetadata& m) {
  for (const VendorXmp& v : Vendors()) {
    if (!HasVendorXmp(xmp, v)) continue;
    m.xmp_vendor = v.vendor;
    for (const VendorTag& t : v.tags) {
      std::optional<double> value = XmpRealOrRational(xmp, t.key, t.name, source);
      CheckRange(value, t.lo, t.hi, fmt::format("XMP {}", t.name).c_str(), source);
      if (value && t.conv == Conv::kPix4dPitch) {
        // Into (-180, 180]: Pix4D's pitch 0 (nadir) is -90, its 90 (forward) is 0.
        double p = std::remainder(*value - 90.0, 360.0);
        if (p == -180.0) p = 180.0;
        value = p;
      }
      m.*(t.field) = value;
    }
    return;
  }
}

// A text tag of a rig (a band name, a capture id) as written, trimmed; the first item of an
// rdf:Seq or rdf:Bag (MicaSense writes some tags so). InputError naming the file for text no
// camera writes (over 64 bytes, control characters): it would end up in the run's messages.
std::string XmpRigText(const Exiv2::XmpData& xmp, const char* key, const char* what,
                       const std::string& source) {
  const auto it = xmp.findKey(Exiv2::XmpKey(key));
  if (it == xmp.end() || it->count() == 0) return "";
  const std::string text = it->toString(0);
  const std::string_view t = TrimSpace(text);
  const bool printable = std::all_of(t.begin(), t.end(), [](char c) {
    return static_cast<unsigned char>(c) >= 0x20 && c != 0x7f;
  });
  if (t.size() > 64 || !printable) {
    throw InputError(
        fmt::format("{}: XMP {} '{}' is not a {} a camera writes (at most 64 "
                    "printable characters)",
                    source, what, Printable(t, 40), what));
  }
  return std::string(t);
}

// The rig's tags of a photo (ImageMetadata::band_name, capture_id, rig_camera_index,
// image_source).
void ReadRigXmp(const Exiv2::XmpData& xmp, const std::string& source, ImageMetadata& m) {
  m.band_name = XmpRigText(xmp, "Xmp.Camera.BandName", "Camera:BandName", source);
  m.image_source = XmpRigText(xmp, "Xmp.drone-dji.ImageSource", "drone-dji:ImageSource", source);
  for (const auto& [key, what] : {std::pair{"Xmp.drone-dji.CaptureUUID", "drone-dji:CaptureUUID"},
                                  {"Xmp.MicaSense.CaptureId", "MicaSense:CaptureId"},
                                  {"Xmp.Camera.CaptureUUID", "Camera:CaptureUUID"},
                                  {"Xmp.Camera.ImageUniqueID", "Camera:ImageUniqueID"}}) {
    if (m.capture_id.empty()) m.capture_id = XmpRigText(xmp, key, what, source);
  }
  const auto index = XmpNumber(xmp, "Xmp.Camera.RigCameraIndex", source);
  if (index) {
    if (*index < 0.0 || *index > 1000.0 || *index != std::floor(*index)) {
      throw InputError(
          fmt::format("{}: XMP Camera:RigCameraIndex {} is not a camera index in "
                      "[0, 1000]",
                      source, *index));
    }
    m.rig_camera_index = static_cast<int>(*index);
  }
}

ImageMetadata Extract(Exiv2::Image& image, const std::string& source) {
  image.readMetadata();
  ImageMetadata m;
  m.source = source;
  m.width_px = image.pixelWidth();
  m.height_px = image.pixelHeight();
  const Exiv2::ExifData& exif = image.exifData();
  // The XMP places in ImageMetadata::XmpSource order: the first with DJI values, else the first
  // with another vendor's values (Vendors()), else the first with a packet.
  using Src = ImageMetadata::XmpSource;
  // The packets are decoded only when the APP1 segment has no DJI values.
  const bool app1_dji = HasDjiXmp(image.xmpData());
  Exiv2::XmpData ifd0_xmp, exif_ifd_xmp;
  const bool has_ifd0 = !app1_dji && XmpFromExifPacket(exif, Exiv2::ExifKey("Exif.Image.XMLPacket"),
                                                       "IFD0 XMLPacket", source, &ifd0_xmp);
  const bool has_exif_ifd =
      !app1_dji && XmpFromExifPacket(exif, Exiv2::ExifKey(0x02bc, "Photo"),
                                     "Exif sub-IFD ApplicationNotes", source, &exif_ifd_xmp);
  const std::pair<const Exiv2::XmpData*, Src> places[] = {
      {image.xmpData().empty() ? nullptr : &image.xmpData(), Src::kApp1Segment},
      {has_ifd0 ? &ifd0_xmp : nullptr, Src::kIfd0XmlPacket},
      {has_exif_ifd ? &exif_ifd_xmp : nullptr, Src::kExifIfdApplicationNotes}};
  const Exiv2::XmpData empty_xmp;
  const Exiv2::XmpData* chosen = nullptr;
  for (const auto& [data, src] : places) {
    if (data != nullptr && HasDjiXmp(*data)) {
      chosen = data;
      m.xmp_source = src;
      break;
    }
  }
  for (const auto& [data, src] : places) {
    if (chosen == nullptr && data != nullptr && HasOtherVendorXmp(*data)) {
      chosen = data;
      m.xmp_source = src;
    }
  }
  for (const auto& [data, src] : places) {
    if (chosen == nullptr && data != nullptr) {
      chosen = data;
      m.xmp_source = src;
    }
  }
  const Exiv2::XmpData& xmp = chosen != nullptr ? *chosen : empty_xmp;
  m.xmp_from_exif_packet =
      m.xmp_source == Src::kIfd0XmlPacket || m.xmp_source == Src::kExifIfdApplicationNotes;
  if (m.width_px <= 0 || m.height_px <= 0) {
    // EXIF's own idea of the size, a fallback only: a value that is no plausible pixel count
    // (1e300 would not even convert to int) leaves the size unknown.
    const auto pixels = [&](const char* key) {
      const double v = ExifNumber(exif, key, source).value_or(0.0);
      return v >= 1.0 && v <= 1e6 ? static_cast<int>(v) : 0;
    };
    m.width_px = pixels("Exif.Photo.PixelXDimension");
    m.height_px = pixels("Exif.Photo.PixelYDimension");
  }
  ReadCameraIdentity(exif, xmp, m);

  ReadExifGps(exif, source, m);

  ReadCaptureTime(exif, m);

  m.focal_length_mm = ExifNumber(exif, "Exif.Photo.FocalLength", source);
  m.focal_length_35mm_mm = ExifNumber(exif, "Exif.Photo.FocalLengthIn35mmFilm", source);
  // 0 means "unknown" in EXIF.
  if (m.focal_length_mm && *m.focal_length_mm == 0.0) m.focal_length_mm.reset();
  if (m.focal_length_35mm_mm && *m.focal_length_35mm_mm == 0.0) m.focal_length_35mm_mm.reset();
  CheckRange(m.focal_length_mm, 0.0, 1e4, "EXIF FocalLength (mm)", source);
  CheckRange(m.focal_length_35mm_mm, 0.0, 1e4, "EXIF FocalLengthIn35mmFilm (mm)", source);
  // FocalPlaneXResolution of the Exif sub-IFD (EXIF 2.32), else of IFD0 (TIFF/EP's tag 0x920e).
  // Its unit: 2 inch (also when absent), 3 cm (EXIF 2.32); 4 mm and 5 um (TIFF/EP).
  for (const char* group : {"Exif.Photo.", "Exif.Image."}) {
    const std::string prefix(group);
    const auto res = ExifNumber(exif, (prefix + "FocalPlaneXResolution").c_str(), source);
    if (m.focal_plane_px_per_mm || !res || !(*res > 0.0) || !std::isfinite(*res)) continue;
    const double unit =
        ExifNumber(exif, (prefix + "FocalPlaneResolutionUnit").c_str(), source).value_or(2.0);
    const double mm = unit == 2 ? 25.4 : unit == 3 ? 10.0 : unit == 4 ? 1.0 : unit == 5 ? 1e-3 : 0;
    if (mm > 0.0) m.focal_plane_px_per_mm = *res / mm;
  }
  CheckRange(m.focal_plane_px_per_mm, 1e-3, 1e5, "EXIF FocalPlaneXResolution (px/mm)", source);

  ReadRigXmp(xmp, source, m);
  ReadDjiXmp(xmp, source, m);
  const bool dji_values = m.rel_alt_m || m.abs_alt_m || m.flight_yaw_deg || m.flight_pitch_deg ||
                          m.flight_roll_deg || m.gimbal_yaw_deg || m.gimbal_pitch_deg ||
                          m.gimbal_roll_deg || m.calibrated_focal_px || m.calibrated_cx_px ||
                          m.calibrated_cy_px;
  // A photo with DJI values keeps them (another vendor's tags beside them are not read).
  if (dji_values) {
    m.xmp_vendor = ImageMetadata::XmpVendor::kDji;
  } else {
    ReadOtherVendorXmp(xmp, source, m);
  }
  return m;
}

}  // namespace

const char* XmpVendorName(ImageMetadata::XmpVendor vendor) {
  switch (vendor) {
    case ImageMetadata::XmpVendor::kDji:
      return "DJI drone-dji";
    case ImageMetadata::XmpVendor::kParrot:
      return "Parrot drone-parrot";
    case ImageMetadata::XmpVendor::kPix4dCamera:
      return "Pix4D Camera";
    case ImageMetadata::XmpVendor::kSenseFlyCamera:
      return "senseFly Camera";
    case ImageMetadata::XmpVendor::kNone:
      break;
  }
  return "none";
}

TelemetrySample ImageMetadata::ToSample() const {
  TelemetrySample s;
  s.lat_deg = lat_deg.value_or(0.0);
  s.lon_deg = lon_deg.value_or(0.0);
  s.unix_time_s = capture_unix_time_s;
  s.abs_alt_m = abs_alt_m ? abs_alt_m : gps_alt_m;
  s.rel_alt_m = rel_alt_m;
  s.yaw_deg = flight_yaw_deg;
  s.pitch_deg = flight_pitch_deg;
  s.roll_deg = flight_roll_deg;
  s.gimbal_yaw_deg = gimbal_yaw_deg;
  s.gimbal_pitch_deg = gimbal_pitch_deg;
  s.gimbal_roll_deg = gimbal_roll_deg;
  s.focal_length_mm = focal_length_mm;
  s.focal_length_35mm_mm = focal_length_35mm_mm;
  s.origin = source;
  return s;
}

namespace {

// Opens the image with `open` (file or memory) and extracts its metadata; every failure becomes
// one InputError naming `source`.
template <class Open>
ImageMetadata OpenAndExtract(Open open, const std::string& source) {
  try {
    auto image = open();
    if (image.get() == nullptr) {
      throw InputError(fmt::format("cannot read metadata of '{}': unknown format", source));
    }
    return Extract(*image, source);
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    throw InputError(fmt::format("cannot read metadata of '{}': {}", source, ExivWhat(e)));
  }
}

}  // namespace

ImageMetadata ReadImageMetadata(const std::filesystem::path& path) {
  InitExiv2Once();
  const std::string source = path.string();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw InputError(
        fmt::format("cannot read metadata of '{}': {}", source,
                    std::filesystem::exists(path, ec) ? "not a regular file" : "no such file"));
  }
  return OpenAndExtract([&] { return Exiv2::ImageFactory::open(source, /*useCurl=*/false); },
                        source);
}

ImageMetadata ParseImageMetadata(const std::uint8_t* data, std::size_t size,
                                 const std::string& source_name) {
  InitExiv2Once();
  if (data == nullptr || size == 0) {
    throw InputError(fmt::format("cannot read metadata of '{}': empty data", source_name));
  }
  return OpenAndExtract([&] { return Exiv2::ImageFactory::open(data, static_cast<long>(size)); },
                        source_name);
}

namespace {

bool AllTimed(const std::vector<ImageMetadata>& images) {
  return !images.empty() && std::all_of(images.begin(), images.end(), [](const ImageMetadata& m) {
    return m.capture_unix_time_s.has_value();
  });
}

// PhotoTimes with the runs of shared capture times it spread.
std::vector<double> PhotoTimes(const std::vector<ImageMetadata>& images,
                               std::vector<RepeatedTimeRun>* spread) {
  std::vector<double> times(images.size());
  if (!AllTimed(images)) {
    for (std::size_t i = 0; i < images.size(); ++i) times[i] = static_cast<double>(i);
    return times;
  }
  for (std::size_t i = 0; i < images.size(); ++i) {
    times[i] = *images[i].capture_unix_time_s - *images.front().capture_unix_time_s;
  }
  const std::vector<RepeatedTimeRun> runs = RepeatedTimeRuns(times);
  for (const RepeatedTimeRun& run : runs) {
    // A run lies within the resolution of its capture time (a whole second without
    // SubSecTimeOriginal), also when every photo has the same time and RepeatedTimeRuns knows
    // no step.
    double resolution_s = 0.0;
    for (std::size_t k = 0; k < run.count; ++k) {
      resolution_s = std::max(resolution_s, images[run.first + k].capture_time_resolution_s);
    }
    RepeatedTimeRun r = run;
    r.step_s = r.step_s > 0.0 ? std::min(r.step_s, resolution_s) : resolution_s;
    for (std::size_t k = 1; k < r.count; ++k) times[r.first + k] = SpreadTime(r, k);
  }
  if (spread != nullptr) *spread = runs;
  return times;
}

}  // namespace

std::vector<double> PhotoTimes(const std::vector<ImageMetadata>& images) {
  return PhotoTimes(images, nullptr);
}

TelemetryReadResult TelemetryFromImages(const std::vector<ImageMetadata>& images,
                                        const TelemetryReadOptions& options) {
  Validate(options);
  // Messages name the photo, or the folder all the photos are in.
  std::string source = "photo set";
  if (images.size() == 1) {
    source = images.front().source;
  } else if (!images.empty()) {
    const std::filesystem::path folder = std::filesystem::path(images.front().source).parent_path();
    if (std::all_of(images.begin(), images.end(), [&](const ImageMetadata& m) {
          return std::filesystem::path(m.source).parent_path() == folder;
        })) {
      source = folder.string();
    }
  }
  io_detail::RecordErrors errors(options, source);
  const bool all_timed = AllTimed(images);
  if (!images.empty() && !all_timed) {
    errors.warnings().push_back(
        fmt::format("{}: not every photo has a capture time: time_s is the photo's rank", source));
  }
  std::vector<RepeatedTimeRun> runs;
  const std::vector<double> times = PhotoTimes(images, &runs);
  if (!runs.empty()) {
    std::size_t photos = 0;
    for (const RepeatedTimeRun& r : runs) photos += r.count;
    errors.warnings().push_back(fmt::format(
        "{}: {} photos share their capture time with another (EXIF times have whole seconds "
        "without SubSecTimeOriginal), first '{}': spread evenly within the time's resolution",
        source, photos, images[runs.front().first].source));
  }
  std::vector<TelemetrySample> samples;
  int no_fix = 0;
  std::optional<double> last;
  for (std::size_t k = 0; k < images.size(); ++k) {
    const ImageMetadata& m = images[k];
    if (!m.HasGps() || (*m.lat_deg == 0.0 && *m.lon_deg == 0.0)) {
      ++no_fix;
      continue;
    }
    TelemetrySample s = m.ToSample();
    s.frame_index = static_cast<int>(k);
    if (all_timed) {
      const double t = *m.capture_unix_time_s;
      if (last && t < *last) {
        errors.ReportMessage(fmt::format(
            "{}: capture time {:.3f} s earlier than the previous photo's (out of order)", m.source,
            *last - t));
        continue;
      }
      last = t;
    }
    s.time_s = times[k];
    try {
      ValidateSample(s, m.source);
    } catch (const InputError& e) {
      errors.ReportMessage(e.what());
      continue;
    }
    samples.push_back(s);
  }
  return io_detail::Finish(std::move(samples), errors, no_fix, "photo set");
}

}  // namespace aerovo

#pragma GCC diagnostic pop
