#include "aerovo/sim/terrain.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "aerovo/core/error.h"
#include "aerovo/sim/random.h"

namespace aerovo::sim {

void Validate(const TerrainOptions& o) {
  auto fail = [](const std::string& what) { throw InvalidArgument("TerrainOptions: " + what); };
  if (o.width_px < 64 || o.height_px < 64 || o.width_px > 32768 || o.height_px > 32768) {
    fail(fmt::format("image size {}x{} px must be within 64..32768 per side", o.width_px,
                     o.height_px));
  }
  if (!(o.metres_per_px > 0.01 && o.metres_per_px <= 10.0)) {
    fail(fmt::format("metres_per_px = {} must be in (0.01, 10]", o.metres_per_px));
  }
  if (!(o.field_size_m >= 10.0 && o.field_size_m <= 2000.0)) {
    fail(fmt::format("field_size_m = {} must be in [10, 2000]", o.field_size_m));
  }
  for (double f : {o.village_fraction, o.forest_fraction, o.orchard_fraction}) {
    if (!(f >= 0.0 && f <= 1.0)) fail(fmt::format("a land-use fraction = {} is outside [0, 1]", f));
  }
  if (o.village_fraction + o.forest_fraction + o.orchard_fraction > 1.0 + 1e-9) {
    fail("village_fraction + forest_fraction + orchard_fraction must not exceed 1");
  }
  if (o.road_every_n_lines < 1 || o.road_every_n_lines > 100) {
    fail(fmt::format("road_every_n_lines = {} must be in [1, 100]", o.road_every_n_lines));
  }
  if (!(o.texture_contrast >= 0.0 && o.texture_contrast <= 1.0)) {
    fail(fmt::format("texture_contrast = {} must be in [0, 1]", o.texture_contrast));
  }
  if (!std::isfinite(o.sun_azimuth_deg)) fail("sun_azimuth_deg must be finite");
  if (!(o.shadow_length_per_height >= 0.0 && o.shadow_length_per_height <= 10.0)) {
    fail(fmt::format("shadow_length_per_height = {} must be in [0, 10]",
                     o.shadow_length_per_height));
  }
  if (!(o.blur_sigma_px >= 0.0 && o.blur_sigma_px <= 10.0)) {
    fail(fmt::format("blur_sigma_px = {} must be in [0, 10]", o.blur_sigma_px));
  }
}

namespace {

// Two uniform draws in [a, b) as (first, second), the second drawn FIRST, in separate statements:
// the evaluation order of a call's arguments is unspecified (GCC on x86-64 evaluates them right
// to left, on aarch64 left to right), so a call with two draws as arguments, like the former
// cv::Point2f(rng.Uniform(-1, 1), rng.Uniform(-1, 1)), gave another terrain per architecture for
// one seed. Second-first is the order x86-64 GCC used, so the x86 terrains are unchanged.
cv::Point2f UniformPairSecondFirst(Rng& rng, double a, double b) {
  const float second = static_cast<float>(rng.Uniform(a, b));
  const float first = static_cast<float>(rng.Uniform(a, b));
  return cv::Point2f(first, second);
}

using Quad = std::array<cv::Point2f, 4>;  // corners in order a, b, c, d (b = a + u, d = a + v)

enum class Kind { kCrop, kStubble, kPloughed, kMeadow, kVillage, kForest, kOrchard };

struct Field {
  Quad quad;
  Kind kind = Kind::kMeadow;
  cv::Vec3f colour;            // BGR base colour, 0..255
  float cos_a = 1, sin_a = 0;  // crop-row direction (unit normal of the rows)
  float inv_period = 0;        // 1 / row period (1/px); 0 = no rows
  float row_amp = 0;           // relative contrast of the rows
  float tram_inv_period = 0;   // tramlines (tractor tracks every 12-24 m); 0 = none
  float warp = 0;              // row bending, in periods per unit of warp noise
  float patch_amp = 0;         // contrast of the low-frequency patchiness
};

struct Building {
  std::array<cv::Point2f, 4> corners;  // long side first: c0->c1 along the ridge
  float height_px;
  cv::Vec3f roof;
  bool flat;
};

struct Tree {
  cv::Point2f centre;
  float radius_px;
  cv::Vec3f colour;
};

cv::Point2f Bilinear(const Quad& q, float u, float v) {
  return (1 - u) * (1 - v) * q[0] + u * (1 - v) * q[1] + u * v * q[2] + (1 - u) * v * q[3];
}

// Zero-mean, unit-variance Gaussian noise with correlation length `scale_px`, of size `size`.
// Drawn at a coarse grid and bicubically upsampled, which is much faster than filtering.
cv::Mat SmoothNoise(cv::Size size, double scale_px, std::uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat out;
  if (scale_px <= 1.5) {
    out.create(size, CV_32F);
    rng.fill(out, cv::RNG::NORMAL, 0.0, 1.0);
    return out;
  }
  const int cw = std::max(2, static_cast<int>(std::ceil(size.width / scale_px)) + 1);
  const int ch = std::max(2, static_cast<int>(std::ceil(size.height / scale_px)) + 1);
  cv::Mat coarse(ch, cw, CV_32F);
  rng.fill(coarse, cv::RNG::NORMAL, 0.0, 1.0);
  cv::resize(coarse, out, size, 0, 0, cv::INTER_CUBIC);
  // Bicubic interpolation between independent samples lowers the variance (about 0.6 of it);
  // rescale so that weights below mean contrast.
  cv::Scalar mean, stddev;
  cv::meanStdDev(out, mean, stddev);
  if (stddev[0] > 1e-6) out.convertTo(out, CV_32F, 1.0 / stddev[0], -mean[0] / stddev[0]);
  return out;
}

cv::Vec3f Jitter(Rng& rng, cv::Vec3f c, float rel) {
  const float g = 1.0f + rel * static_cast<float>(rng.Uniform(-1, 1));
  cv::Vec3f out;
  for (int k = 0; k < 3; ++k) {
    out[k] = std::clamp(c[k] * g * (1.0f + 0.05f * static_cast<float>(rng.Uniform(-1, 1))), 0.0f,
                        255.0f);
  }
  return out;
}

cv::Scalar ToScalar(cv::Vec3f c) { return cv::Scalar(c[0], c[1], c[2]); }

std::vector<cv::Point> ToPoints(const cv::Point2f* p, int n, int shift) {
  std::vector<cv::Point> out(n);
  const float s = static_cast<float>(1 << shift);
  for (int i = 0; i < n; ++i) out[i] = cv::Point(cvRound(p[i].x * s), cvRound(p[i].y * s));
  return out;
}

constexpr int kShift = 4;  // sub-pixel bits for OpenCV drawing: smoother edges

void FillPoly(cv::Mat& img, const cv::Point2f* p, int n, const cv::Scalar& colour) {
  const std::vector<cv::Point> pts = ToPoints(p, n, kShift);
  cv::fillConvexPoly(img, pts, colour, cv::LINE_AA, kShift);
}

void Line(cv::Mat& img, cv::Point2f a, cv::Point2f b, const cv::Scalar& colour, double width_px) {
  const float s = static_cast<float>(1 << kShift);
  cv::line(img, cv::Point(cvRound(a.x * s), cvRound(a.y * s)),
           cv::Point(cvRound(b.x * s), cvRound(b.y * s)), colour,
           std::max(1, static_cast<int>(std::lround(width_px))), cv::LINE_AA, kShift);
}

void Circle(cv::Mat& img, cv::Point2f c, float r, const cv::Scalar& colour) {
  const float s = static_cast<float>(1 << kShift);
  cv::circle(img, cv::Point(cvRound(c.x * s), cvRound(c.y * s)),
             std::max(1, static_cast<int>(std::lround(r * s))), colour, cv::FILLED, cv::LINE_AA,
             kShift);
}

}  // namespace

cv::Mat GenerateTerrain(const TerrainOptions& o) {
  Validate(o);
  const int W = o.width_px, H = o.height_px;
  const float px_per_m = static_cast<float>(1.0 / o.metres_per_px);
  const cv::Size size(W, H);
  Rng rng(SubSeed(o.seed, 1));

  // Sun and shadow geometry in image coordinates (x east, y south).
  const double az = o.sun_azimuth_deg * CV_PI / 180.0;
  const cv::Point2f to_sun(static_cast<float>(std::sin(az)), static_cast<float>(-std::cos(az)));
  const cv::Point2f shadow_dir = -to_sun * static_cast<float>(o.shadow_length_per_height);

  // ---- Parcel grid: rows and columns of irregular spacing, every node jittered, so the
  // fields are irregular quadrilaterals; the grid overhangs the image by one cell.
  const float cell = static_cast<float>(o.field_size_m) * px_per_m;
  auto make_lines = [&](int extent) {
    std::vector<float> lines{-cell * static_cast<float>(rng.Uniform(0.5, 1.0))};
    while (lines.back() < extent + cell) {
      lines.push_back(lines.back() + cell * static_cast<float>(rng.Uniform(0.6, 1.4)));
    }
    return lines;
  };
  const std::vector<float> xs = make_lines(W), ys = make_lines(H);
  const int nx = static_cast<int>(xs.size()), ny = static_cast<int>(ys.size());
  std::vector<cv::Point2f> nodes(static_cast<size_t>(nx) * ny);
  auto node = [&](int i, int j) -> cv::Point2f& { return nodes[static_cast<size_t>(j) * nx + i]; };
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      const cv::Point2f jitter = UniformPairSecondFirst(rng, -1, 1);
      node(i, j) = cv::Point2f(xs[i] + cell * 0.18f * jitter.x, ys[j] + cell * 0.18f * jitter.y);
    }
  }

  // ---- Fields: one quad per cell, half of them split into two strips.
  std::vector<Field> fields;
  auto add_field = [&](const Quad& q) {
    Field f;
    f.quad = q;
    const double r = rng.Uniform();
    double acc = o.village_fraction;
    const double rest = 1.0 - o.village_fraction - o.forest_fraction - o.orchard_fraction;
    if (r < acc) {
      f.kind = Kind::kVillage;
    } else if (r < (acc += o.forest_fraction)) {
      f.kind = Kind::kForest;
    } else if (r < (acc += o.orchard_fraction)) {
      f.kind = Kind::kOrchard;
    } else {
      const double s = (r - acc) / std::max(rest, 1e-9);
      f.kind = s < 0.4   ? Kind::kCrop
               : s < 0.6 ? Kind::kStubble
               : s < 0.8 ? Kind::kPloughed
                         : Kind::kMeadow;
    }
    // Rows run along one of the quad's sides, give or take a few degrees.
    const cv::Point2f side = rng.Uniform() < 0.5 ? q[1] - q[0] : q[3] - q[0];
    const float ang = std::atan2(side.y, side.x) + static_cast<float>(rng.Uniform(-0.05, 0.05));
    f.cos_a = -std::sin(ang);
    f.sin_a = std::cos(ang);
    switch (f.kind) {
      case Kind::kCrop: {
        static const cv::Vec3f palette[] = {
            {70, 150, 100}, {55, 125, 80}, {80, 170, 190}, {60, 160, 150}, {45, 105, 65}};
        f.colour = Jitter(rng, palette[rng.Int(5)], 0.12f);
        f.inv_period = 1.0f / (static_cast<float>(rng.Uniform(1.2, 3.5)) * px_per_m);
        f.row_amp = static_cast<float>(rng.Uniform(0.12, 0.25));
        if (rng.Uniform() < 0.6) {
          f.tram_inv_period = 1.0f / (static_cast<float>(rng.Uniform(12, 24)) * px_per_m);
        }
        f.warp = static_cast<float>(rng.Uniform(0.5, 2.0));
        f.patch_amp = 0.08f;
        break;
      }
      case Kind::kStubble:
        f.colour = Jitter(rng, {120, 180, 210}, 0.1f);
        f.inv_period = 1.0f / (static_cast<float>(rng.Uniform(3.0, 7.0)) * px_per_m);
        f.row_amp = static_cast<float>(rng.Uniform(0.08, 0.16));
        f.warp = static_cast<float>(rng.Uniform(0.3, 1.0));
        f.patch_amp = 0.12f;
        break;
      case Kind::kPloughed:
        f.colour = Jitter(
            rng, rng.Uniform() < 0.5 ? cv::Vec3f(70, 95, 125) : cv::Vec3f(105, 140, 170), 0.12f);
        f.inv_period = 1.0f / (static_cast<float>(rng.Uniform(0.8, 1.6)) * px_per_m);
        f.row_amp = static_cast<float>(rng.Uniform(0.15, 0.3));
        f.warp = static_cast<float>(rng.Uniform(1.0, 3.0));
        f.patch_amp = 0.15f;
        break;
      case Kind::kMeadow:
        f.colour = Jitter(rng, {75, 150, 115}, 0.12f);
        f.patch_amp = 0.22f;
        break;
      case Kind::kVillage:
        f.colour = Jitter(rng, {85, 140, 115}, 0.08f);
        f.patch_amp = 0.2f;
        break;
      case Kind::kForest:
        f.colour = Jitter(rng, {35, 70, 45}, 0.1f);
        f.patch_amp = 0.15f;
        break;
      case Kind::kOrchard:
        f.colour = Jitter(rng, {85, 155, 125}, 0.08f);
        f.patch_amp = 0.15f;
        break;
    }
    fields.push_back(f);
  };
  for (int j = 0; j + 1 < ny; ++j) {
    for (int i = 0; i + 1 < nx; ++i) {
      const Quad q{node(i, j), node(i + 1, j), node(i + 1, j + 1), node(i, j + 1)};
      if (rng.Uniform() < 0.5) {
        const float t = static_cast<float>(rng.Uniform(0.3, 0.7));
        if (rng.Uniform() < 0.5) {  // split along u
          const cv::Point2f e = q[0] + t * (q[1] - q[0]), f = q[3] + t * (q[2] - q[3]);
          add_field({q[0], e, f, q[3]});
          add_field({e, q[1], q[2], f});
        } else {
          const cv::Point2f e = q[0] + t * (q[3] - q[0]), f = q[1] + t * (q[2] - q[1]);
          add_field({q[0], q[1], f, e});
          add_field({e, f, q[2], q[3]});
        }
      } else {
        add_field(q);
      }
    }
  }
  if (fields.size() >= 65535) {
    throw InvalidArgument(fmt::format(
        "TerrainOptions: {} fields exceed 65534; increase field_size_m", fields.size()));
  }

  // ---- Field id map, and the textured field layer.
  cv::Mat ids(size, CV_16U, cv::Scalar(0));
  for (size_t k = 0; k < fields.size(); ++k) {
    const std::vector<cv::Point> pts = ToPoints(fields[k].quad.data(), 4, kShift);
    cv::fillConvexPoly(ids, pts, cv::Scalar(static_cast<double>(k)), cv::LINE_8, kShift);
  }
  // Row bending and amplitude fade: low-frequency fields at quarter resolution (enough for
  // structures tens of metres across, and four times cheaper).
  const cv::Size qsize((W + 3) / 4, (H + 3) / 4);
  const cv::Mat warp_q = SmoothNoise(qsize, 40.0 * px_per_m / 4, SubSeed(o.seed, 2));
  const cv::Mat patch_q = SmoothNoise(qsize, 12.0 * px_per_m / 4, SubSeed(o.seed, 3));
  constexpr int kLut = 1024;
  std::array<float, kLut> row_lut{}, tram_lut{};
  for (int i = 0; i < kLut; ++i) {
    const double t = (i + 0.5) / kLut;
    row_lut[i] = static_cast<float>(std::cos(2 * CV_PI * t));
    const double d = (t - 0.5) / 0.035;  // tramline: a narrow dark groove
    tram_lut[i] = static_cast<float>(-std::exp(-d * d));
  }
  cv::Mat img(size, CV_8UC3);
  cv::parallel_for_(cv::Range(0, H), [&](const cv::Range& range) {
    for (int y = range.start; y < range.end; ++y) {
      const std::uint16_t* id_row = ids.ptr<std::uint16_t>(y);
      const float* wq = warp_q.ptr<float>(y >> 2);
      const float* pq = patch_q.ptr<float>(y >> 2);
      cv::Vec3b* out = img.ptr<cv::Vec3b>(y);
      for (int x = 0; x < W; ++x) {
        const Field& f = fields[id_row[x]];
        const float a = pq[x >> 2];
        float t = 1.0f + f.patch_amp * a;
        if (f.inv_period > 0) {
          const float along = x * f.cos_a + y * f.sin_a;
          const float ph = along * f.inv_period + f.warp * wq[x >> 2];
          const float fr = ph - std::floor(ph);
          t += f.row_amp * (0.7f + 0.3f * a) * row_lut[static_cast<int>(fr * kLut) & (kLut - 1)];
          if (f.tram_inv_period > 0) {
            const float pt = along * f.tram_inv_period + 0.1f * wq[x >> 2];
            const float ft = pt - std::floor(pt);
            t += 0.35f * tram_lut[static_cast<int>(ft * kLut) & (kLut - 1)];
          }
        }
        for (int k = 0; k < 3; ++k) out[x][k] = cv::saturate_cast<std::uint8_t>(f.colour[k] * t);
      }
    }
  });
  ids.release();

  // ---- Linear features along the parcel grid: grass margins everywhere, some dirt tracks and
  // hedgerows, and paved roads on every n-th grid line (polylines through the jittered nodes).
  std::vector<Tree> trees;
  const cv::Vec3f kTreeGreen(40, 95, 50);
  const cv::Scalar margin(70, 135, 95);
  for (const Field& f : fields) {
    for (int k = 0; k < 4; ++k) Line(img, f.quad[k], f.quad[(k + 1) % 4], margin, 1.2 * px_per_m);
  }
  auto edge_features = [&](cv::Point2f a, cv::Point2f b) {
    const double r = rng.Uniform();
    if (r < 0.25) {  // dirt track, with darker wheel ruts
      Line(img, a, b, ToScalar(Jitter(rng, {135, 160, 180}, 0.1f)), 3.0 * px_per_m);
      const cv::Point2f d = b - a;
      const float len = std::max(1e-3f, static_cast<float>(cv::norm(d)));
      const cv::Point2f n(-d.y / len * 0.8f * px_per_m, d.x / len * 0.8f * px_per_m);
      Line(img, a + n, b + n, cv::Scalar(100, 120, 140), 0.4 * px_per_m);
      Line(img, a - n, b - n, cv::Scalar(100, 120, 140), 0.4 * px_per_m);
    } else if (r < 0.45) {  // hedgerow: trees at irregular spacing
      const float len = static_cast<float>(cv::norm(b - a));
      for (float s = 0; s < len;) {
        const float rad = static_cast<float>(rng.Uniform(1.2, 3.5)) * px_per_m;
        const cv::Point2f c =
            a + (s / len) * (b - a) + UniformPairSecondFirst(rng, -1, 1) * px_per_m;
        trees.push_back({c, rad, Jitter(rng, kTreeGreen, 0.2f)});
        s += rad * static_cast<float>(rng.Uniform(1.2, 3.5));
      }
    }
  };
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i + 1 < nx; ++i) edge_features(node(i, j), node(i + 1, j));
  }
  for (int i = 0; i < nx; ++i) {
    for (int j = 0; j + 1 < ny; ++j) edge_features(node(i, j), node(i, j + 1));
  }
  auto road = [&](const std::vector<cv::Point2f>& pts) {
    const double width = rng.Uniform(5.5, 8.0) * px_per_m;
    const cv::Scalar asphalt = ToScalar(Jitter(rng, {88, 86, 84}, 0.1f));
    for (size_t k = 0; k + 1 < pts.size(); ++k) {
      Line(img, pts[k], pts[k + 1], cv::Scalar(120, 135, 140), width + 1.5 * px_per_m);
    }
    for (size_t k = 0; k + 1 < pts.size(); ++k) Line(img, pts[k], pts[k + 1], asphalt, width);
    // Centre-line dashes with irregular gaps (no exact period: matching stays unambiguous).
    for (size_t k = 0; k + 1 < pts.size(); ++k) {
      const cv::Point2f d = pts[k + 1] - pts[k];
      const float len = static_cast<float>(cv::norm(d));
      for (float s = static_cast<float>(rng.Uniform(0, 6)) * px_per_m; s < len;) {
        const float dash = static_cast<float>(rng.Uniform(2.5, 3.5)) * px_per_m;
        const float e = std::min(len, s + dash);
        Line(img, pts[k] + (s / len) * d, pts[k] + (e / len) * d, cv::Scalar(215, 220, 225),
             0.25 * px_per_m);
        s = e + static_cast<float>(rng.Uniform(5.0, 9.0)) * px_per_m;
      }
    }
  };
  for (int i = rng.Int(o.road_every_n_lines); i < nx; i += o.road_every_n_lines) {
    std::vector<cv::Point2f> pts;
    for (int j = 0; j < ny; ++j) pts.push_back(node(i, j));
    road(pts);
  }
  for (int j = rng.Int(o.road_every_n_lines); j < ny; j += o.road_every_n_lines) {
    std::vector<cv::Point2f> pts;
    for (int i = 0; i < nx; ++i) pts.push_back(node(i, j));
    road(pts);
  }

  // ---- Objects inside parcels: buildings (villages), trees (forests, orchards, meadows).
  std::vector<Building> buildings;
  for (const Field& f : fields) {
    const cv::Point2f du = f.quad[1] - f.quad[0], dv = f.quad[3] - f.quad[0];
    const float lu = std::max(1.0f, static_cast<float>(cv::norm(du)));
    const float lv = std::max(1.0f, static_cast<float>(cv::norm(dv)));
    // Skip parcels entirely outside the image.
    float x0 = f.quad[0].x, x1 = x0, y0 = f.quad[0].y, y1 = y0;
    for (const auto& p : f.quad) {
      x0 = std::min(x0, p.x), x1 = std::max(x1, p.x), y0 = std::min(y0, p.y),
      y1 = std::max(y1, p.y);
    }
    if (x0 > W || y0 > H || x1 < 0 || y1 < 0) continue;
    if (f.kind == Kind::kVillage) {
      const float step = 22.0f * px_per_m;
      for (float v = step * 0.5f / lv; v < 1.0f; v += step / lv) {
        for (float u = step * 0.5f / lu; u < 1.0f; u += step / lu) {
          if (rng.Uniform() < 0.2) {
            trees.push_back({Bilinear(f.quad, u, v),
                             static_cast<float>(rng.Uniform(2.0, 5.0)) * px_per_m,
                             Jitter(rng, kTreeGreen, 0.2f)});
            continue;
          }
          const float uu = u + static_cast<float>(rng.Uniform(-0.15, 0.15)) * step / lu;
          const float vv = v + static_cast<float>(rng.Uniform(-0.15, 0.15)) * step / lv;
          const cv::Point2f c = Bilinear(f.quad, uu, vv);
          float ang = std::atan2(du.y, du.x) + static_cast<float>(rng.Uniform(-0.12, 0.12));
          if (rng.Uniform() < 0.3) ang += static_cast<float>(CV_PI / 2);
          const float len = static_cast<float>(rng.Uniform(8, 18)) * px_per_m;
          const float wid = static_cast<float>(rng.Uniform(6, 11)) * px_per_m;
          const cv::Point2f a(std::cos(ang) * len / 2, std::sin(ang) * len / 2);
          const cv::Point2f b(-std::sin(ang) * wid / 2, std::cos(ang) * wid / 2);
          static const cv::Vec3f roofs[] = {
              {55, 75, 165}, {70, 90, 150}, {115, 115, 120}, {80, 80, 90}, {150, 155, 160}};
          Building bd;
          bd.corners = {c - a - b, c + a - b, c + a + b, c - a + b};
          bd.height_px = static_cast<float>(rng.Uniform(3.5, 9.0)) * px_per_m;
          bd.roof = Jitter(rng, roofs[rng.Int(5)], 0.1f);
          bd.flat = rng.Uniform() < 0.3;
          buildings.push_back(bd);
          if (rng.Uniform() < 0.5) {  // garden tree beside the house
            const cv::Point2f t = c + 1.6f * b + a * static_cast<float>(rng.Uniform(-1, 1));
            trees.push_back({t, static_cast<float>(rng.Uniform(1.5, 3.5)) * px_per_m,
                             Jitter(rng, kTreeGreen, 0.2f)});
          }
        }
      }
    } else if (f.kind == Kind::kForest || f.kind == Kind::kOrchard) {
      const bool forest = f.kind == Kind::kForest;
      const float step = (forest ? 4.5f : static_cast<float>(rng.Uniform(5.5, 8.0))) * px_per_m;
      const float jit = forest ? 0.45f : 0.08f;
      for (float v = step * 0.5f / lv; v < 1.0f; v += step / lv) {
        for (float u = step * 0.5f / lu; u < 1.0f; u += step / lu) {
          if (!forest && rng.Uniform() < 0.08) continue;  // missing tree
          const float uu = u + static_cast<float>(rng.Uniform(-jit, jit)) * step / lu;
          const float vv = v + static_cast<float>(rng.Uniform(-jit, jit)) * step / lv;
          const float rad =
              static_cast<float>(forest ? rng.Uniform(1.8, 4.5) : rng.Uniform(1.4, 2.4)) * px_per_m;
          trees.push_back({Bilinear(f.quad, uu, vv), rad,
                           Jitter(rng, forest ? cv::Vec3f(35, 85, 45) : kTreeGreen, 0.25f)});
        }
      }
    } else if (f.kind == Kind::kMeadow) {
      const int n = static_cast<int>(lu * lv / (900.0f * px_per_m * px_per_m));  // 1 per 30x30 m
      for (int k = 0; k < n; ++k) {
        const cv::Point2f uv = UniformPairSecondFirst(rng, 0, 1);
        const cv::Point2f c = Bilinear(f.quad, uv.x, uv.y);
        trees.push_back({c, static_cast<float>(rng.Uniform(1.0, 4.0)) * px_per_m,
                         Jitter(rng, kTreeGreen, 0.25f)});
      }
    }
  }

  // ---- Shadows: one mask, then a bluish darkening (skylight fills the shadows).
  cv::Mat shadow(size, CV_8U, cv::Scalar(0));
  for (const Building& b : buildings) {
    const cv::Point2f off = shadow_dir * b.height_px;
    std::vector<cv::Point2f> pts(b.corners.begin(), b.corners.end());
    for (const auto& c : b.corners) pts.push_back(c + off);
    std::vector<cv::Point2f> hull;
    cv::convexHull(pts, hull);
    FillPoly(shadow, hull.data(), static_cast<int>(hull.size()), cv::Scalar(255));
  }
  for (const Tree& t : trees) {
    Circle(shadow, t.centre + shadow_dir * (2.2f * t.radius_px), t.radius_px * 0.95f,
           cv::Scalar(255));
  }
  cv::parallel_for_(cv::Range(0, H), [&](const cv::Range& range) {
    for (int y = range.start; y < range.end; ++y) {
      const std::uint8_t* m = shadow.ptr<std::uint8_t>(y);
      cv::Vec3b* p = img.ptr<cv::Vec3b>(y);
      for (int x = 0; x < W; ++x) {
        if (m[x] == 0) continue;
        const float s = m[x] * (1.0f / 255.0f);
        static constexpr float kDark[3] = {0.62f, 0.52f, 0.47f};
        for (int k = 0; k < 3; ++k) {
          p[x][k] = static_cast<std::uint8_t>(p[x][k] * (1.0f - s * (1.0f - kDark[k])) + 0.5f);
        }
      }
    }
  });
  shadow.release();

  // ---- Roofs (gabled: the half facing the sun is brighter) and tree crowns.
  for (const Building& b : buildings) {
    const auto& c = b.corners;
    if (b.flat) {
      FillPoly(img, c.data(), 4, ToScalar(b.roof * 0.8f));
      const cv::Point2f centre = 0.25f * (c[0] + c[1] + c[2] + c[3]);
      std::array<cv::Point2f, 4> inner;
      for (int k = 0; k < 4; ++k) inner[k] = centre + 0.85f * (c[k] - centre);
      FillPoly(img, inner.data(), 4, ToScalar(b.roof));
      // Roof fixtures (vents, AC units): small dark and bright squares.
      const int n = 1 + rng.Int(3);
      for (int k = 0; k < n; ++k) {
        const cv::Point2f uv = UniformPairSecondFirst(rng, 0.2, 0.8);
        const cv::Point2f p = Bilinear({inner[0], inner[1], inner[2], inner[3]}, uv.x, uv.y);
        const float h = static_cast<float>(rng.Uniform(0.6, 1.2)) * px_per_m;
        const cv::Point2f sq[4] = {p + cv::Point2f(-h, -h), p + cv::Point2f(h, -h),
                                   p + cv::Point2f(h, h), p + cv::Point2f(-h, h)};
        FillPoly(img, sq, 4,
                 rng.Uniform() < 0.5 ? cv::Scalar(60, 60, 60) : cv::Scalar(200, 200, 200));
      }
    } else {
      const cv::Point2f m0 = 0.5f * (c[0] + c[3]), m1 = 0.5f * (c[1] + c[2]);
      const cv::Point2f half_a[4] = {c[0], c[1], m1, m0};
      const cv::Point2f half_b[4] = {m0, m1, c[2], c[3]};
      const cv::Point2f normal_a = c[0] - m0;  // outward direction of half a
      const bool a_lit = normal_a.dot(to_sun) > 0;
      FillPoly(img, half_a, 4, ToScalar(b.roof * (a_lit ? 1.15f : 0.72f)));
      FillPoly(img, half_b, 4, ToScalar(b.roof * (a_lit ? 0.72f : 1.15f)));
      Line(img, m0, m1, ToScalar(b.roof * 0.6f), std::max(1.0, 0.3 * px_per_m));
    }
  }
  for (const Tree& t : trees) {
    Circle(img, t.centre, t.radius_px, ToScalar(t.colour * 0.8f));
    Circle(img, t.centre + to_sun * (0.3f * t.radius_px), t.radius_px * 0.6f,
           ToScalar(t.colour * 1.25f));
  }

  // ---- Multi-scale brightness texture over everything (soil moisture, vegetation vigour,
  // surface detail): octaves from 0.5 m to 128 m, combined into one relative modulation.
  if (o.texture_contrast > 0) {
    const double scales_m[] = {0.5, 2.0, 8.0, 32.0, 128.0};
    const double weights[] = {0.35, 0.5, 0.5, 0.4, 0.3};
    double wsum2 = 0;
    for (double w : weights) wsum2 += w * w;
    cv::Mat mod(size, CV_32F, cv::Scalar(0));
    for (int k = 0; k < 5; ++k) {
      const cv::Mat n = SmoothNoise(size, scales_m[k] * px_per_m, SubSeed(o.seed, 10 + k));
      cv::scaleAdd(n, weights[k] * o.texture_contrast / std::sqrt(wsum2), mod, mod);
    }
    cv::parallel_for_(cv::Range(0, H), [&](const cv::Range& range) {
      for (int y = range.start; y < range.end; ++y) {
        const float* m = mod.ptr<float>(y);
        cv::Vec3b* p = img.ptr<cv::Vec3b>(y);
        for (int x = 0; x < W; ++x) {
          const float g = std::max(0.0f, 1.0f + m[x]);
          for (int k = 0; k < 3; ++k) p[x][k] = cv::saturate_cast<std::uint8_t>(p[x][k] * g);
        }
      }
    });
  }
  if (o.blur_sigma_px > 0) cv::GaussianBlur(img, img, cv::Size(0, 0), o.blur_sigma_px);
  return img;
}

}  // namespace aerovo::sim
