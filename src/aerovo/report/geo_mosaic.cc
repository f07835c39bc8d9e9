#include "aerovo/report/geo_mosaic.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <optional>

#include <cpl_conv.h>
#include <cpl_vsi.h>
#include <fmt/format.h>
#include <gdal_priv.h>
#include <ogr_spatialref.h>
#include <Eigen/Dense>
#include <GeographicLib/UTMUPS.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/core/error.h"
#include "aerovo/eval/trajectory_eval.h"
#include "aerovo/geo/local_enu.h"
#include "aerovo/imageio/image_io.h"
#include "aerovo/report/mosaic_warp.h"

namespace aerovo {
namespace fs = std::filesystem;

std::vector<std::string> GeoMosaicFileNames::All() { return {kGeoTiff, kKmz, kPng, kJson}; }

namespace {

using Affine = Eigen::Matrix<double, 2, 3>;

Eigen::Matrix3d Homogeneous(const Affine& a) {
  Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
  m.topRows<2>() = a;
  return m;
}

cv::Matx23d ToCv(const Affine& a) {
  return cv::Matx23d(a(0, 0), a(0, 1), a(0, 2), a(1, 0), a(1, 1), a(1, 2));
}

std::string XmlEscape(const std::string& s) {
  std::string out;
  for (const char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

void RegisterGdal() {
  static std::once_flag once;
  std::call_once(once, [] { GDALAllRegister(); });
}

// `tmp` renamed onto `path`, or InputError naming `path`.
void Commit(const fs::path& tmp, const fs::path& path) {
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw InputError("cannot write '" + path.string() + "': " + ec.message());
  }
}

// RGBA (alpha 255 where covered) from a BGR canvas and its coverage.
cv::Mat Bgra(const MosaicWarpTarget& t) {
  cv::Mat bgra;
  cv::cvtColor(t.bgr, bgra, cv::COLOR_BGR2BGRA);
  std::vector<cv::Mat> ch;
  cv::split(bgra, ch);
  ch[3] = t.coverage.clone();
  for (int c = 0; c < 3; ++c) ch[c].setTo(0, t.coverage == 0);  // clean nodata pixels
  cv::merge(ch, bgra);
  return bgra;
}

void WritePng(const cv::Mat& bgra, const fs::path& path) {
  const fs::path tmp = path.parent_path() / (path.stem().string() + ".tmp.png");
  bool ok = false;
  try {
    ok = imageio::Write(tmp.string(), bgra);
  } catch (const cv::Exception& e) {
    throw InputError("cannot write '" + path.string() + "': " + e.what());
  }
  if (!ok) throw InputError("cannot write '" + path.string() + "'");
  Commit(tmp, path);
}

// GeoTIFF: 4 bands (R, G, B, alpha), deflate, the UTM CRS and a north-up geotransform.
void WriteGeoTiff(const cv::Mat& bgra, const fs::path& path, int zone, bool north, int epsg,
                  const double geotransform[6]) {
  RegisterGdal();
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  if (!driver) throw InputError("cannot write '" + path.string() + "': GDAL has no GTiff driver");
  const fs::path tmp = path.parent_path() / (path.stem().string() + ".tmp.tif");
  char** opts = nullptr;
  opts = CSLSetNameValue(opts, "COMPRESS", "DEFLATE");
  opts = CSLSetNameValue(opts, "PHOTOMETRIC", "RGB");
  opts = CSLSetNameValue(opts, "ALPHA", "YES");
  GDALDataset* ds = driver->Create(tmp.c_str(), bgra.cols, bgra.rows, 4, GDT_Byte, opts);
  CSLDestroy(opts);
  if (!ds) {
    throw InputError("cannot write '" + path.string() + "': " + CPLGetLastErrorMsg());
  }
  double gt[6];
  std::copy(geotransform, geotransform + 6, gt);
  bool ok = ds->SetGeoTransform(gt) == CE_None;
  OGRSpatialReference srs;
  if (srs.importFromEPSG(epsg) != OGRERR_NONE) {  // no PROJ database: the same CRS by parameters
    srs.Clear();
    srs.SetWellKnownGeogCS("WGS84");
    srs.SetUTM(zone, north ? TRUE : FALSE);
  }
  ok = ok && ds->SetSpatialRef(&srs) == CE_None;
  // bgra is B, G, R, A interleaved: bands 1..3 (R, G, B) read bytes 2, 1, 0; band 4 byte 3.
  cv::Mat rgba;
  cv::cvtColor(bgra, rgba, cv::COLOR_BGRA2RGBA);
  int bands[4] = {1, 2, 3, 4};
  ok = ok && ds->RasterIO(GF_Write, 0, 0, rgba.cols, rgba.rows, rgba.data, rgba.cols, rgba.rows,
                          GDT_Byte, 4, bands, 4, static_cast<GSpacing>(rgba.step), 1,
                          nullptr) == CE_None;
  GDALClose(ds);
  if (!ok) {
    std::error_code ec;
    fs::remove(tmp, ec);
    throw InputError("cannot write '" + path.string() + "': " + CPLGetLastErrorMsg());
  }
  Commit(tmp, path);
}

// One file added to the zip `zip` (GDAL's /vsizip/ writer, deflate).
void AddToZip(const fs::path& zip, const std::string& name, const std::string& bytes,
              const fs::path& path_for_errors) {
  VSILFILE* f = VSIFOpenL(("/vsizip/" + zip.string() + "/" + name).c_str(), "wb");
  if (!f) {
    throw InputError("cannot write '" + path_for_errors.string() + "': " + CPLGetLastErrorMsg());
  }
  const bool ok = VSIFWriteL(bytes.data(), 1, bytes.size(), f) == bytes.size();
  const bool closed = VSIFCloseL(f) == 0;
  if (!ok || !closed) {
    throw InputError("cannot write '" + path_for_errors.string() + "': " + CPLGetLastErrorMsg());
  }
}

std::string ReadBytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// KMZ: doc.kml first (what Google Earth opens), then the overlay image.
void WriteKmz(const fs::path& path, const std::string& name, const fs::path& png,
              const GeoMosaicResult& r) {
  RegisterGdal();
  const std::string kml = fmt::format(
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<kml xmlns=\"http://www.opengis.net/kml/2.2\">\n"
      "<Document>\n<name>{0} mosaic</name>\n"
      "<GroundOverlay>\n<name>{0}</name>\n"
      "<description>aerovo orthomosaic: frames warped by the estimated transforms, "
      "geo-referenced through the VO track ({1:.2f} m per pixel)</description>\n"
      "<Icon><href>{2}</href></Icon>\n"
      "<LatLonBox>\n<north>{3:.8f}</north>\n<south>{4:.8f}</south>\n<east>{5:.8f}</east>\n"
      "<west>{6:.8f}</west>\n<rotation>0</rotation>\n</LatLonBox>\n"
      "</GroundOverlay>\n</Document>\n</kml>\n",
      XmlEscape(name), r.m_per_px, GeoMosaicFileNames::kPng, r.north_deg, r.south_deg, r.east_deg,
      r.west_deg);
  const fs::path tmp = path.parent_path() / (path.stem().string() + ".tmp.kmz");
  std::error_code ec;
  fs::remove(tmp, ec);
  try {
    AddToZip(tmp, "doc.kml", kml, path);
    AddToZip(tmp, GeoMosaicFileNames::kPng, ReadBytes(png), path);
  } catch (...) {
    fs::remove(tmp, ec);
    throw;
  }
  Commit(tmp, path);
}

}  // namespace

GeoMosaicResult WriteGeoMosaic(const RunData& run, const fs::path& dir, const std::string& name,
                               const MosaicOptions& options) {
  Validate(options);
  GeoMosaicResult r;
  // Frame centres in first-frame pixels paired with their geo-referenced VO positions.
  std::vector<int> frames;
  const std::vector<Eigen::Vector2d> centres = FrameCentresPx(run, &frames);
  std::map<int, GeoPoint> geo_of;
  for (const RunFrameRow& f : run.frames) {
    if (f.geo) geo_of[f.frame] = *f.geo;
  }
  std::vector<Eigen::Vector2d> px;
  std::vector<GeoPoint> geo;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const auto it = geo_of.find(frames[i]);
    if (it == geo_of.end()) continue;
    px.push_back(centres[i]);
    geo.push_back(it->second);
  }
  if (geo.size() < 3) {
    r.note =
        "no geo mosaic (mosaic.tif, mosaic.kmz, mosaic_geo.png): the run is not geo-referenced "
        "(fewer than 3 frames with a position in frames.csv: no GPS, or no heading)";
    return r;
  }
  if (const std::string problem = MosaicInputProblem(run); !problem.empty()) {
    r.note = "no geo mosaic: " + problem;
    return r;
  }
  int w = 0, h = 0;
  MosaicFrameSize(run, &w, &h);

  // ENU plane at the mean VO position; first px -> ENU similarity (pixels have y down).
  GeoPoint origin{0.0, 0.0, 0.0};
  for (const GeoPoint& g : geo) {
    origin.lat_deg += g.lat_deg / geo.size();
    origin.lon_deg += g.lon_deg / geo.size();
    origin.alt_m += g.alt_m / geo.size();
  }
  const LocalEnu enu(origin);
  std::vector<TrajectoryPoint2D> est, ref;
  for (std::size_t i = 0; i < geo.size(); ++i) {
    const Eigen::Vector3d e = enu.Forward(geo[i]);
    est.push_back({0.0, px[i].x(), -px[i].y()});
    ref.push_back({0.0, e.x(), e.y()});
  }
  AlignmentResult fit;
  try {
    fit = AlignUmeyama2D(est, ref, AlignmentModel::kSim2);
  } catch (const InvalidArgument& e) {
    r.note = std::string("no geo mosaic: the frames' pixels and positions do not fit: ") + e.what();
    return r;
  }
  r.fit_rmse_m = fit.rmse_m;
  const Eigen::Matrix3d enu_from_first =
      fit.enu_from_vo.Matrix() * Eigen::Vector3d(1.0, -1.0, 1.0).asDiagonal();
  auto enu_of = [&](double u, double v) -> Eigen::Vector2d {
    return (enu_from_first * Eigen::Vector3d(u, v, 1.0)).head<2>();
  };

  // UTM zone of the flight's centre.
  int zone = 0;
  bool north = origin.lat_deg >= 0.0;
  try {
    zone = GeographicLib::UTMUPS::StandardZone(origin.lat_deg, origin.lon_deg);
  } catch (const std::exception& e) {
    r.note = std::string("no geo mosaic: no UTM zone for the flight's centre: ") + e.what();
    return r;
  }
  if (zone < 1) {
    r.note = "no geo mosaic: the flight is in a polar region (UPS, not UTM)";
    return r;
  }
  auto utm_of = [&](const Eigen::Vector2d& e) -> Eigen::Vector2d {
    const GeoPoint g = enu.Reverse(e.x(), e.y(), 0.0);
    double x = 0, y = 0, gamma = 0, k = 0;
    int z = 0;
    bool n = north;
    GeographicLib::UTMUPS::Forward(g.lat_deg, g.lon_deg, z, n, x, y, gamma, k, zone);
    if (n != north) y += north ? -10000000.0 : 10000000.0;  // flight across the equator
    return {x, y};
  };

  // Every frame corner in first-frame pixels; their ENU bounds.
  double u0 = 1e300, v0 = 1e300, u1 = -1e300, v1 = -1e300;
  std::vector<Eigen::Vector2d> corners_px;
  // The frames placed as the mosaic warps them (MosaicPlacements: the optimised poses when the
  // run has them); the first-frame pixel -> ENU similarity fitted above on the causal ones holds
  // for both (transforms_optimized.csv keeps transforms.csv's first-frame pixels).
  const std::vector<FrameTransformRow>& placements = MosaicPlacements(run, options);
  r.optimized = &placements == &run.transforms_optimized;
  // The corners of the frames as drawn: through the virtual nadir camera (MosaicNadirFromFrame).
  for (const FrameTransformRow& t : placements) {
    const Eigen::Matrix3d nadir_from_frame = MosaicNadirFromFrame(run, w, h, t.frame);
    for (const auto& [x, y] : {std::pair<double, double>{-0.5, -0.5}, {w - 0.5, -0.5},
                               {w - 0.5, h - 0.5}, {-0.5, h - 0.5}}) {
      const Eigen::Vector3d q = nadir_from_frame * Eigen::Vector3d(x, y, 1.0);
      const double cx = q.x() / q.z(), cy = q.y() / q.z();
      const Eigen::Vector2d p(t.a[0] * cx + t.a[1] * cy + t.a[2],
                              t.a[3] * cx + t.a[4] * cy + t.a[5]);
      if (!p.allFinite()) continue;
      corners_px.push_back(p);
      u0 = std::min(u0, p.x());
      v0 = std::min(v0, p.y());
      u1 = std::max(u1, p.x());
      v1 = std::max(v1, p.y());
    }
  }
  if (corners_px.empty() || !(u1 > u0) || !(v1 > v0)) {
    r.note = "no geo mosaic: the transforms are degenerate";
    return r;
  }
  // ENU -> UTM as one affine over the mosaic (least squares on a 9x9 grid; residual reported).
  std::vector<Eigen::Vector2d> grid_px;
  for (int i = 0; i <= 8; ++i) {
    for (int j = 0; j <= 8; ++j) grid_px.emplace_back(u0 + (u1 - u0) * i / 8, v0 + (v1 - v0) * j / 8);
  }
  Eigen::MatrixXd a(grid_px.size(), 3), b(grid_px.size(), 2);
  for (std::size_t i = 0; i < grid_px.size(); ++i) {
    a.row(i) << grid_px[i].x(), grid_px[i].y(), 1.0;
    b.row(i) = utm_of(enu_of(grid_px[i].x(), grid_px[i].y())).transpose();
  }
  const Eigen::MatrixXd sol = a.colPivHouseholderQr().solve(b);  // 3x2
  Affine utm_from_first = sol.transpose();
  double utm_residual_m = 0.0;
  for (std::size_t i = 0; i < grid_px.size(); ++i) {
    utm_residual_m = std::max(
        utm_residual_m, (utm_from_first * Eigen::Vector3d(grid_px[i].x(), grid_px[i].y(), 1.0) -
                         b.row(i).transpose())
                            .norm());
  }

  double e0 = 1e300, n0 = 1e300, e1 = -1e300, n1 = -1e300;  // ENU bounds
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;  // UTM bounds
  for (const Eigen::Vector2d& p : corners_px) {
    const Eigen::Vector2d e = enu_of(p.x(), p.y());
    e0 = std::min(e0, e.x());
    n0 = std::min(n0, e.y());
    e1 = std::max(e1, e.x());
    n1 = std::max(n1, e.y());
    const Eigen::Vector2d g = utm_from_first * Eigen::Vector3d(p.x(), p.y(), 1.0);
    x0 = std::min(x0, g.x());
    y0 = std::min(y0, g.y());
    x1 = std::max(x1, g.x());
    y1 = std::max(y1, g.y());
  }
  // Ground sampling: the longer side within max_size_px, not finer than the frames' own pixels.
  const double native_m = fit.enu_from_vo.scale;
  const double span = std::max({e1 - e0, n1 - n0, x1 - x0, y1 - y0});
  const double m = std::max(native_m, span / options.max_size_px) * (1.0 + 1e-9);
  if (!(m > 0.0) || !std::isfinite(m) || !(span > 0.0)) {
    r.note = "no geo mosaic: the geo-reference of the frames is degenerate";
    return r;
  }
  r.m_per_px = m;
  r.width_px = std::max(1, static_cast<int>(std::ceil((e1 - e0) / m)));
  r.height_px = std::max(1, static_cast<int>(std::ceil((n1 - n0) / m)));
  r.tif_width_px = std::max(1, static_cast<int>(std::ceil((x1 - x0) / m)));
  r.tif_height_px = std::max(1, static_cast<int>(std::ceil((y1 - y0) / m)));
  // Centre the images on the frames' bounds (the rounding shared on both sides).
  const double ew = 0.5 * (e0 + e1) - 0.5 * r.width_px * m, ee = ew + r.width_px * m;
  const double nn = 0.5 * (n0 + n1) + 0.5 * r.height_px * m, ns = nn - r.height_px * m;
  const double xw = 0.5 * (x0 + x1) - 0.5 * r.tif_width_px * m;
  const double yn = 0.5 * (y0 + y1) + 0.5 * r.tif_height_px * m;

  // canvas (pixel centres at integers) from ENU / UTM metres.
  Affine canvas_from_enu;
  canvas_from_enu << 1.0 / m, 0.0, -ew / m - 0.5, 0.0, -1.0 / m, nn / m - 0.5;
  Affine canvas_from_utm;
  canvas_from_utm << 1.0 / m, 0.0, -xw / m - 0.5, 0.0, -1.0 / m, yn / m - 0.5;
  std::vector<MosaicWarpTarget> targets(2);
  targets[0].canvas_from_first = ToCv(canvas_from_enu * enu_from_first);
  targets[0].bgr = cv::Mat(r.height_px, r.width_px, CV_8UC3, cv::Scalar(0, 0, 0));
  targets[0].coverage = cv::Mat(r.height_px, r.width_px, CV_8UC1, cv::Scalar(0));
  targets[1].canvas_from_first = ToCv(canvas_from_utm * Homogeneous(utm_from_first));
  targets[1].bgr = cv::Mat(r.tif_height_px, r.tif_width_px, CV_8UC3, cv::Scalar(0, 0, 0));
  targets[1].coverage = cv::Mat(r.tif_height_px, r.tif_width_px, CV_8UC1, cv::Scalar(0));
  const MosaicWarpOutcome warp = WarpRunFrames(run, options, targets);
  if (!warp.ok) {
    r.note = "no geo mosaic: " + warp.note;
    return r;
  }
  r.frames_used = warp.frames_used;

  // The overlay's lat/lon edges (mid-edges of the ENU rectangle) and how far the linear stretch
  // between them puts the corners from where they are in the ENU plane.
  const double ec = 0.5 * (ew + ee), nc = 0.5 * (ns + nn);
  r.south_deg = enu.Reverse(ec, ns, 0.0).lat_deg;
  r.north_deg = enu.Reverse(ec, nn, 0.0).lat_deg;
  r.west_deg = enu.Reverse(ew, nc, 0.0).lon_deg;
  r.east_deg = enu.Reverse(ee, nc, 0.0).lon_deg;
  double overlay_error_m = 0.0;
  for (const auto& [e, n, lat, lon] :
       {std::tuple<double, double, double, double>{ew, ns, r.south_deg, r.west_deg},
        {ee, ns, r.south_deg, r.east_deg},
        {ee, nn, r.north_deg, r.east_deg},
        {ew, nn, r.north_deg, r.west_deg}}) {
    const Eigen::Vector3d at = enu.Forward(lat, lon, origin.alt_m);
    overlay_error_m = std::max(overlay_error_m, (at.head<2>() - Eigen::Vector2d(e, n)).norm());
  }
  r.utm_zone = zone;
  r.utm_north = north;
  r.epsg = (north ? 32600 : 32700) + zone;

  std::error_code ec_dir;
  fs::create_directories(dir, ec_dir);
  const fs::path png = dir / GeoMosaicFileNames::kPng;
  const fs::path tif = dir / GeoMosaicFileNames::kGeoTiff;
  const fs::path kmz = dir / GeoMosaicFileNames::kKmz;
  const fs::path json = dir / GeoMosaicFileNames::kJson;
  WritePng(Bgra(targets[0]), png);
  const double gt[6] = {xw, m, 0.0, yn, 0.0, -m};
  WriteGeoTiff(Bgra(targets[1]), tif, zone, north, r.epsg, gt);
  WriteKmz(kmz, name, png, r);
  nlohmann::json j = {{"image", GeoMosaicFileNames::kPng},
                      {"south", r.south_deg},
                      {"west", r.west_deg},
                      {"north", r.north_deg},
                      {"east", r.east_deg},
                      {"width_px", r.width_px},
                      {"height_px", r.height_px},
                      {"m_per_px", m},
                      {"overlay_max_error_m", overlay_error_m},
                      {"geotiff", GeoMosaicFileNames::kGeoTiff},
                      {"geotiff_epsg", r.epsg},
                      {"fit_rmse_m", fit.rmse_m},
                      {"frames_used", warp.frames_used},
                      {"optimized", r.optimized}};
  {
    const fs::path tmp = dir / "mosaic_geo.tmp.json";
    std::ofstream out(tmp);
    out << j.dump(2) << "\n";
    out.close();
    if (!out) throw InputError("cannot write '" + json.string() + "'");
    Commit(tmp, json);
  }
  r.written = true;
  r.files = {tif, kmz, png, json};
  r.note = fmt::format(
      "mosaic.tif (UTM zone {}{}, EPSG:{}, {}x{} px), mosaic.kmz, mosaic_geo.png ({}x{} px): "
      "{:.2f} m per px, {} frames{}, fit RMS {:.2f} m, UTM affine residual {:.3f} m",
      zone, north ? "N" : "S", r.epsg, r.tif_width_px, r.tif_height_px, r.width_px, r.height_px, m,
      warp.frames_used, r.optimized ? " placed by the optimised poses" : "", fit.rmse_m,
      utm_residual_m);
  return r;
}

}  // namespace aerovo
