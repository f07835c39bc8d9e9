// Same keypoints and matches on every architecture: SURF (MATLAB defaults) and the exhaustive
// matcher on a fixed synthetic image pair, compared with testdata/surf_match_golden.txt, written
// on x86-64 (AVX2 + FMA kernels). scripts/test-aarch64.sh runs this test on aarch64 under qemu
// (NEON / portable kernels, AEROVO_SIMD=native and scalar); the x86 builds run it too.
//
// The images are made with integer arithmetic only (no libm, no OpenCV), so both architectures
// start from the same bytes. Floating-point results may differ in the last bits: the x86 AVX2
// kernels and aarch64 (where GCC contracts a*b+c into fused multiply-adds unless
// -ffp-contract=off) round some sums differently, and libm's atan2/exp differ by an ulp between
// implementations. Tolerances (what "the same" means here):
//   - keypoint count, order (by response), Laplacian sign and octave: exact;
//   - x, y: 1e-3 px; scale: 1e-4 px; orientation: 1e-4 rad; response: 1e-5 relative;
//   - descriptor values: 1e-4 (the first kFullDescriptors descriptors of each image in full, all
//     of them through two checksums, sum and index-weighted sum, to 1e-3);
//   - matches: the same (prev, curr) pairs; SSD to 1e-4.
// The largest differences found are recorded as test properties (--gtest_output=xml) and in
// BENCHMARKS.md ("aarch64 cross build").
//
// Regenerate (after a change that is meant to change SURF or the matcher, on x86):
//   AEROVO_UPDATE_GOLDEN=1 build/src/aerovo/matching/aerovo_matching_test
//       --gtest_filter=SurfMatchGolden.*
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "aerovo/core/image.h"
#include "aerovo/features/surf.h"
#include "aerovo/matching/matcher.h"

namespace aerovo::surf_match_golden_test {
namespace {

constexpr int kWidth = 320, kHeight = 240;
// The second image is the texture moved by (-kDx, -kDy): a point (u, v) of the first is at
// (u - kDx, v - kDy) in the second.
constexpr int kDx = 13, kDy = -7;
constexpr int kFullDescriptors = 4;
constexpr double kTolPx = 1e-3, kTolScale = 1e-4, kTolAngle = 1e-4, kTolResponseRel = 1e-5;
constexpr double kTolDescriptor = 1e-4, kTolChecksum = 1e-3, kTolSsd = 1e-4;

std::uint64_t SplitMix(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

int Lattice(int ix, int iy, int octave) {
  const std::uint64_t key = (static_cast<std::uint64_t>(static_cast<std::uint32_t>(ix)) << 32) ^
                            static_cast<std::uint32_t>(iy) ^
                            (static_cast<std::uint64_t>(octave) << 58);
  return static_cast<int>(SplitMix(key) & 255);
}

// Value noise at (x, y) (x, y >= 0): cells of 32, 16, 8 and 4 px (amplitudes 8, 4, 2, 1),
// bilinear with integer weights; 0..255.
int Noise(int x, int y) {
  std::int64_t sum = 0, total = 0;
  for (int o = 0; o < 4; ++o) {
    const int cell = 32 >> o, amp = 8 >> o;
    const int ix = x / cell, iy = y / cell, fx = x % cell, fy = y % cell;
    const std::int64_t top = Lattice(ix, iy, o) * (cell - fx) + Lattice(ix + 1, iy, o) * fx;
    const std::int64_t bot = Lattice(ix, iy + 1, o) * (cell - fx) + Lattice(ix + 1, iy + 1, o) * fx;
    sum += amp * ((top * (cell - fy) + bot * fy) / cell);  // 0..255 * cell
    total += amp * cell;
  }
  return static_cast<int>(sum / total);
}

// The texture both images are cut from: the noise at half contrast plus kDiscs filled discs
// (radius 2..13 px, bright or dark): SURF's blobs. Integer arithmetic only.
constexpr int kTexWidth = kWidth + 80, kTexHeight = kHeight + 80, kDiscs = 300;
std::vector<int> MakeTexture() {
  std::vector<int> t(static_cast<std::size_t>(kTexWidth) * kTexHeight);
  for (int y = 0; y < kTexHeight; ++y) {
    for (int x = 0; x < kTexWidth; ++x) t[y * kTexWidth + x] = 64 + Noise(x, y) / 2;
  }
  for (int i = 0; i < kDiscs; ++i) {
    const std::uint64_t h = SplitMix(0xd15c0000ULL + static_cast<std::uint64_t>(i));
    const int cx = static_cast<int>(h % kTexWidth), cy = static_cast<int>((h >> 16) % kTexHeight);
    const int r = 2 + static_cast<int>((h >> 32) % 12), delta = ((h >> 40) & 1) ? 70 : -70;
    for (int y = std::max(0, cy - r); y <= std::min(kTexHeight - 1, cy + r); ++y) {
      for (int x = std::max(0, cx - r); x <= std::min(kTexWidth - 1, cx + r); ++x) {
        if ((x - cx) * (x - cx) + (y - cy) * (y - cy) <= r * r) t[y * kTexWidth + x] += delta;
      }
    }
  }
  return t;
}

GrayImage Crop(const std::vector<int>& texture, int x0, int y0) {
  GrayImage image(kWidth, kHeight);
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      image.at(x, y) =
          static_cast<std::uint8_t>(std::clamp(texture[(y0 + y) * kTexWidth + x0 + x], 0, 255));
    }
  }
  return image;
}

struct Computed {
  FeatureSet prev, curr;
  std::vector<Match> matches;
};

Computed Compute() {
  Computed c;
  Surf surf;  // MATLAB defaults (threshold 1000, 3 octaves, 4 levels, 64-value descriptor)
  const std::vector<int> texture = MakeTexture();
  const GrayImage a = Crop(texture, 40, 40), b = Crop(texture, 40 + kDx, 40 + kDy);
  c.prev = surf.DetectAndDescribe(a.view()).features;
  c.curr = surf.DetectAndDescribe(b.view()).features;
  c.matches = Matcher().Match(c.prev, c.curr).matches;  // MATLAB matchFeatures defaults
  return c;
}

double Checksum(const FeatureSet& f, std::size_t i, bool weighted) {
  double s = 0.0;
  for (int d = 0; d < f.descriptor_size; ++d) {
    s += (weighted ? (d + 1) / 64.0 : 1.0) * f.descriptor(i)[d];
  }
  return s;
}

std::string GoldenPath() { return std::string(AEROVO_MODULE_TESTDATA) + "/surf_match_golden.txt"; }

void WriteGolden(const Computed& c, const std::string& path) {
  std::ofstream out(path);
  ASSERT_TRUE(out) << path;
  out.precision(9);
  out << "# SURF keypoints and matches of the synthetic pair of surf_match_golden_test.cc (x86-64).\n"
      << "# image NAME COUNT; kp INDEX x y scale orientation response laplacian octave dsum dwsum;\n"
      << "# desc INDEX v0..v63 (first " << kFullDescriptors << "); matches COUNT; m prev curr ssd\n";
  for (const auto* f : {&c.prev, &c.curr}) {
    out << "image " << (f == &c.prev ? "prev" : "curr") << ' ' << f->size() << '\n';
    for (std::size_t i = 0; i < f->size(); ++i) {
      const Keypoint& k = f->keypoints[i];
      out << "kp " << i << ' ' << k.x << ' ' << k.y << ' ' << k.scale << ' ' << k.orientation << ' '
          << k.response << ' ' << int(k.laplacian) << ' ' << int(k.octave) << ' '
          << Checksum(*f, i, false) << ' ' << Checksum(*f, i, true) << '\n';
    }
    for (std::size_t i = 0; i < std::min<std::size_t>(kFullDescriptors, f->size()); ++i) {
      out << "desc " << i;
      for (int d = 0; d < f->descriptor_size; ++d) out << ' ' << f->descriptor(i)[d];
      out << '\n';
    }
  }
  out << "matches " << c.matches.size() << '\n';
  for (const Match& m : c.matches) {
    out << "m " << m.prev_index << ' ' << m.curr_index << ' ' << m.ssd << '\n';
  }
}

struct GoldenKeypoint {
  double x, y, scale, orientation, response, dsum, dwsum;
  int laplacian, octave;
};
struct GoldenImage {
  std::vector<GoldenKeypoint> kps;
  std::vector<std::vector<double>> desc;
};
struct Golden {
  GoldenImage prev, curr;
  std::vector<Match> matches;
};

// Reads the golden file; a malformed line fails the test naming the line.
void ReadGolden(const std::string& path, Golden* g) {
  std::ifstream in(path);
  ASSERT_TRUE(in) << "cannot read " << path;
  std::string line, tag;
  GoldenImage* img = nullptr;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream s(line);
    s >> tag;
    if (tag == "image") {
      std::string name;
      s >> name;
      img = name == "prev" ? &g->prev : &g->curr;
    } else if (tag == "kp") {
      ASSERT_NE(img, nullptr) << path << ':' << n;
      GoldenKeypoint k{};
      std::size_t i = 0;
      s >> i >> k.x >> k.y >> k.scale >> k.orientation >> k.response >> k.laplacian >> k.octave >>
          k.dsum >> k.dwsum;
      ASSERT_TRUE(s && i == img->kps.size()) << path << ':' << n << ": bad keypoint line";
      img->kps.push_back(k);
    } else if (tag == "desc") {
      ASSERT_NE(img, nullptr) << path << ':' << n;
      std::size_t i = 0;
      s >> i;
      std::vector<double> v;
      for (double x; s >> x;) v.push_back(x);
      ASSERT_TRUE(i == img->desc.size() && v.size() == 64) << path << ':' << n << ": bad desc";
      img->desc.push_back(v);
    } else if (tag == "m") {
      Match m;
      s >> m.prev_index >> m.curr_index >> m.ssd;
      ASSERT_TRUE(s) << path << ':' << n << ": bad match line";
      g->matches.push_back(m);
    } else if (tag != "matches") {
      FAIL() << path << ':' << n << ": unknown line '" << line << "'";
    }
  }
}

double AngleDiff(double a, double b) {
  const double two_pi = 2.0 * 3.14159265358979323846;
  double d = std::fmod(std::fabs(a - b), two_pi);
  return std::min(d, two_pi - d);
}

struct MaxDiff {
  double px = 0, scale = 0, angle = 0, response_rel = 0, descriptor = 0, checksum = 0, ssd = 0;
};

void CompareImage(const char* name, const FeatureSet& got, const GoldenImage& want, MaxDiff* md) {
  ASSERT_EQ(got.size(), want.kps.size()) << name << ": keypoint count";
  for (std::size_t i = 0; i < got.size(); ++i) {
    const Keypoint& k = got.keypoints[i];
    const GoldenKeypoint& w = want.kps[i];
    SCOPED_TRACE(std::string(name) + " keypoint " + std::to_string(i));
    ASSERT_EQ(int(k.laplacian), w.laplacian);
    ASSERT_EQ(int(k.octave), w.octave);
    const double px = std::max(std::fabs(k.x - w.x), std::fabs(k.y - w.y));
    const double ds = std::fabs(k.scale - w.scale);
    const double da = AngleDiff(k.orientation, w.orientation);
    const double dr = std::fabs(k.response - w.response) / std::fabs(w.response);
    const double dc = std::max(std::fabs(Checksum(got, i, false) - w.dsum),
                               std::fabs(Checksum(got, i, true) - w.dwsum));
    ASSERT_LE(px, kTolPx) << "x " << k.x << " vs " << w.x << ", y " << k.y << " vs " << w.y;
    ASSERT_LE(ds, kTolScale) << k.scale << " vs " << w.scale;
    ASSERT_LE(da, kTolAngle) << k.orientation << " vs " << w.orientation;
    ASSERT_LE(dr, kTolResponseRel) << k.response << " vs " << w.response;
    ASSERT_LE(dc, kTolChecksum) << "descriptor checksums";
    md->px = std::max(md->px, px);
    md->scale = std::max(md->scale, ds);
    md->angle = std::max(md->angle, da);
    md->response_rel = std::max(md->response_rel, dr);
    md->checksum = std::max(md->checksum, dc);
  }
  for (std::size_t i = 0; i < want.desc.size(); ++i) {
    for (int d = 0; d < 64; ++d) {
      const double dd = std::fabs(got.descriptor(i)[d] - want.desc[i][d]);
      ASSERT_LE(dd, kTolDescriptor) << name << " descriptor " << i << " value " << d;
      md->descriptor = std::max(md->descriptor, dd);
    }
  }
}

TEST(SurfMatchGolden, SameKeypointsAndMatchesAsX86) {
  const Computed c = Compute();
  if (const char* u = std::getenv("AEROVO_UPDATE_GOLDEN"); u && std::string(u) == "1") {
    WriteGolden(c, GoldenPath());
    GTEST_SKIP() << "wrote " << GoldenPath();
  }
  // The pair must be a meaningful test: enough points, mostly true matches.
  ASSERT_GT(c.prev.size(), 150u);
  ASSERT_GT(c.matches.size(), 60u);
  int correct = 0;
  for (const Match& m : c.matches) {
    const Keypoint& p = c.prev.keypoints[m.prev_index];
    const Keypoint& q = c.curr.keypoints[m.curr_index];
    correct += std::hypot(p.x - kDx - q.x, p.y - kDy - q.y) < 0.5;
  }
  EXPECT_GE(correct * 10, static_cast<int>(c.matches.size()) * 9);

  Golden g;
  ASSERT_NO_FATAL_FAILURE(ReadGolden(GoldenPath(), &g));
  MaxDiff md;
  ASSERT_NO_FATAL_FAILURE(CompareImage("prev", c.prev, g.prev, &md));
  ASSERT_NO_FATAL_FAILURE(CompareImage("curr", c.curr, g.curr, &md));
  ASSERT_EQ(c.matches.size(), g.matches.size()) << "match count";
  for (std::size_t i = 0; i < c.matches.size(); ++i) {
    ASSERT_EQ(c.matches[i].prev_index, g.matches[i].prev_index) << "match " << i;
    ASSERT_EQ(c.matches[i].curr_index, g.matches[i].curr_index) << "match " << i;
    const double d = std::fabs(c.matches[i].ssd - g.matches[i].ssd);
    ASSERT_LE(d, kTolSsd) << "match " << i;
    md.ssd = std::max(md.ssd, d);
  }
  RecordProperty("keypoints", std::to_string(c.prev.size()) + "+" + std::to_string(c.curr.size()));
  RecordProperty("matches", static_cast<int>(c.matches.size()));
  std::ostringstream s;
  s.precision(3);
  s << "max |diff| vs x86: position " << md.px << " px, scale " << md.scale << " px, orientation "
    << md.angle << " rad, response " << md.response_rel << " rel, descriptor " << md.descriptor
    << ", checksum " << md.checksum << ", ssd " << md.ssd;
  RecordProperty("max_diff", s.str());
  std::printf("%s (%zu + %zu keypoints, %zu matches)\n", s.str().c_str(), c.prev.size(),
              c.curr.size(), c.matches.size());
}

}  // namespace
}  // namespace aerovo::surf_match_golden_test
