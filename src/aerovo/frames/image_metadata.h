// EXIF / XMP metadata of photos (through Exiv2): GPS position, capture time, XMP flight and
// gimbal attitude and relative altitude (DJI, Parrot, Pix4D Camera, senseFly), focal lengths
// and image size.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "aerovo/telemetry/telemetry_readers.h"

namespace aerovo {

/// What a photo says about itself. Angles in degrees (yaw clockwise from north), lengths in
/// metres unless the name says otherwise. Fields the file does not have stay unset.
struct ImageMetadata {
  std::string source;  ///< Path (or name) the metadata was read from; used in messages.
  int width_px = 0;    ///< Pixel size of the image (decoded header), 0 if unknown.
  int height_px = 0;
  std::string make, model;  ///< EXIF Make / Model ("DJI", "FC300S").
  /// EXIF BodySerialNumber, else CameraSerialNumber, else DJI XMP CameraSerialNumber; empty
  /// when none is written.
  std::string serial_number;
  /// Where the XMP fields below were read. A JPEG's XMP is the APP1 segment of the XMP
  /// specification (part 3, 1.1.3); some cameras store the packet instead in the TIFF tag 0x02bc
  /// (XMLPacket, TIFF/EP; exiftool "IFD0:XMP"), others in the same tag of the Exif sub-IFD
  /// (exiftool "ExifIFD:ApplicationNotes": DJI Zenmuse XT2). The first of these places (in this
  /// order) that holds DJI (drone-dji) values is used, else the first that holds values of
  /// another vendor aerovo reads (XmpVendor), else the first that holds a packet.
  enum class XmpSource { kNone, kApp1Segment, kIfd0XmlPacket, kExifIfdApplicationNotes };
  XmpSource xmp_source = XmpSource::kNone;
  /// Whose XMP flight values (heights and angles below) were read: DJI's drone-dji namespace
  /// when it holds any, else the first of the others, in this order, that holds one of its
  /// tags (docs/inputs.md, "XMP of other vendors"): Parrot (drone-parrot angles, with the
  /// Pix4D Camera AboveGroundAltitude Parrot writes beside them), Pix4D's Camera namespace
  /// (Parrot Sequoia, other multispectral cameras), senseFly's Camera namespace. kNone when
  /// the photo has none of these values.
  enum class XmpVendor { kNone, kDji, kParrot, kPix4dCamera, kSenseFlyCamera };
  XmpVendor xmp_vendor = XmpVendor::kNone;
  /// True when the XMP fields came from an EXIF tag 0x02bc packet (IFD0 or the Exif sub-IFD).
  bool xmp_from_exif_packet = false;

  /// EXIF GPSLatitude/GPSLongitude with their N/S, E/W refs; WGS84 degrees.
  std::optional<double> lat_deg, lon_deg;
  /// EXIF GPSAltitude (negative when GPSAltitudeRef = 1, below sea level).
  std::optional<double> gps_alt_m;
  /// EXIF DateTimeOriginal + SubSecTimeOriginal as seconds since 1970 (the camera's clock has
  /// no time zone; it is read as if UTC). Unset when missing or blank ("    :  :  ").
  std::optional<double> capture_unix_time_s;
  /// The resolution of capture_unix_time_s, seconds: 1 (DateTimeOriginal), 10^-n with n digits
  /// of SubSecTimeOriginal.
  double capture_time_resolution_s = 1.0;

  // XMP flight values, in DJI's convention (namespace drone-dji,
  // http://www.dji.com/drone-dji/1.0/): gimbal pitch -90 = nadir, 0 = horizon; yaw clockwise
  // from north. Other vendors' values (xmp_vendor) are converted to it.
  /// RelativeAltitude: height above the take-off point (Pix4D Camera AboveGroundAltitude:
  /// height above the ground, which Parrot writes).
  std::optional<double> rel_alt_m;
  std::optional<double> abs_alt_m;  ///< AbsoluteAltitude.
  std::optional<double> flight_yaw_deg, flight_pitch_deg, flight_roll_deg;
  std::optional<double> gimbal_yaw_deg, gimbal_pitch_deg, gimbal_roll_deg;
  /// CalibratedFocalLength (pixels, at this image's size) and optical centre, when written.
  std::optional<double> calibrated_focal_px, calibrated_cx_px, calibrated_cy_px;

  // Multi-camera rigs: multispectral cameras write one photo per band at each capture (DJI P4
  // Multispectral: an RGB JPEG and five TIFFs; MicaSense RedEdge and Altum, Parrot Sequoia,
  // Sentera: one TIFF per band). The tags as OpenDroneMap reads them (OpenDroneMap/ODM
  // opendm/photo.py, ODM_Photo.parse_exif_values) and as MicaSense writes them (its TIFFs'
  // XMP: Camera:BandName, Camera:RigCameraIndex, MicaSense:CaptureId).
  /// The band this photo holds: XMP Camera:BandName (Pix4D's namespace), e.g. "Blue", "NIR",
  /// "Red edge"; empty when the photo names none (a rig's RGB camera: DJI P4 Multispectral's
  /// JPEG has none).
  std::string band_name;
  /// The capture this photo belongs to, the same in the photos a rig takes together: XMP
  /// drone-dji:CaptureUUID (DJI), MicaSense:CaptureId (MicaSense), Camera:CaptureUUID (Parrot
  /// Sequoia), Camera:ImageUniqueID (Sentera); empty when none is written.
  std::string capture_id;
  /// XMP Camera:RigCameraIndex: the band's camera in the rig (MicaSense, Sequoia, Sentera).
  std::optional<int> rig_camera_index;
  /// The camera of a DJI payload of several that took the photo: XMP drone-dji:ImageSource,
  /// "WideCamera", "ZoomCamera", "InfraredCamera" (Zenmuse H20T, Matrice 30T, Mavic 3T: one photo
  /// of each camera per capture, DJI_xxxx_W.JPG, _Z.JPG, _T.JPG); empty when not written.
  std::string image_source;

  std::optional<double> focal_length_mm;       ///< EXIF FocalLength.
  std::optional<double> focal_length_35mm_mm;  ///< EXIF FocalLengthIn35mmFilm.
  /// EXIF FocalPlaneXResolution in pixels per millimetre (its FocalPlaneResolutionUnit: 2 inch,
  /// 3 cm, 4 mm, 5 um; EXIF 2.32 and the TIFF/EP units): the sensor's pixel pitch at the image's
  /// own size. Unset when not written, 0, or in a unit EXIF does not define.
  std::optional<double> focal_plane_px_per_mm;

  bool HasGps() const { return lat_deg.has_value() && lon_deg.has_value(); }

  /// The telemetry fix of this photo (time_s = 0, frame_index unset; the caller places it).
  /// abs_alt_m = XMP AbsoluteAltitude, else the EXIF GPS altitude; origin = `source`.
  /// Precondition: HasGps().
  TelemetrySample ToSample() const;
};

/// "DJI drone-dji", "Parrot drone-parrot", "Pix4D Camera", "senseFly Camera"; "none".
const char* XmpVendorName(ImageMetadata::XmpVendor vendor);

/// Reads the metadata of an image file (JPEG, TIFF, PNG, DNG ... whatever Exiv2 reads).
/// Throws InputError "cannot read metadata of '<path>': <reason>" for a missing, unreadable or
/// unrecognised file, and "<path>: EXIF GPS latitude 95 out of range [-90, 90]"-style errors
/// for values out of range or malformed (zero denominators, wrong component counts).
ImageMetadata ReadImageMetadata(const std::filesystem::path& path);

/// The same from an encoded image held in memory (`source_name` is used in messages). This
/// is the entry point the fuzz target drives.
ImageMetadata ParseImageMetadata(const std::uint8_t* data, std::size_t size,
                                 const std::string& source_name);

/// Each photo's time in a sequence, seconds: its capture time - the first photo's when every
/// photo has a capture time, else its rank. Photos that share a capture time (EXIF
/// DateTimeOriginal has whole seconds; many cameras write no SubSecTimeOriginal) are spread
/// evenly within the time's resolution (RepeatedTimeRun, SpreadTime; capture_time_resolution_s),
/// so no two frames have one time.
/// Precondition: capture times in order (ImageFolderSource sorts by them).
std::vector<double> PhotoTimes(const std::vector<ImageMetadata>& images);

/// Telemetry of a photo sequence, in the given order (frame_index = rank in `images`).
/// time_s = PhotoTimes (a warning when photos share a capture time, or when not every photo has
/// one and the rank is used). Photos without GPS are counted in no_fix_records and left out;
/// capture times that go backwards are malformed records (strict: InputError naming the
/// photo; lenient: skipped and counted). Throws InputError when no photo has GPS.
TelemetryReadResult TelemetryFromImages(const std::vector<ImageMetadata>& images,
                                        const TelemetryReadOptions& options = {});

}  // namespace aerovo
