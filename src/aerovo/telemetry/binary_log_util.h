// Internal helpers shared by the readers of binary flight logs (dataflash_reader.cc,
// ulog_reader.cc, tlog_reader.cc; not part of the public API): a bounded read window over the
// input, little-endian loads, and the interpolation of attitude / height series onto GPS times.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <istream>
#include <optional>
#include <vector>

namespace aerovo::io_detail {

/// Attitude and height samples kept at most this often (seconds): a log may hold them at the
/// main-loop rate (ArduPilot's ATT at 400 Hz, PX4's vehicle_attitude at 100-250 Hz, ATTITUDE
/// streamed at 50 Hz), far finer than needed to interpolate onto 5-10 Hz GPS fixes; keeping every
/// one would take hundreds of MB for a long flight.
constexpr double kMinSeriesStepS = 0.02;
/// Series points further apart than this (seconds) are not interpolated between: a gap in the
/// log (InterpolateSeries' max_gap_s).
constexpr double kMaxInterpolationGapS = 1.0;
/// Gaps of unreadable bytes listed one by one in a reader's warnings; the rest are counted.
constexpr int kMaxListedGaps = 5;

/// Little-endian unsigned integer of n (<= 8) bytes at p.
inline std::uint64_t LoadLe(const unsigned char* p, int n) {
  std::uint64_t v = 0;
  for (int k = n - 1; k >= 0; --k) v = (v << 8) | p[k];
  return v;
}

/// IEEE 754 binary32 / binary64 stored little-endian at p.
inline double LoadFloatLe(const unsigned char* p) {
  const std::uint32_t bits = static_cast<std::uint32_t>(LoadLe(p, 4));
  float v;
  std::memcpy(&v, &bits, sizeof v);
  return static_cast<double>(v);
}
inline double LoadDoubleLe(const unsigned char* p) {
  const std::uint64_t bits = LoadLe(p, 8);
  double v;
  std::memcpy(&v, &bits, sizeof v);
  return v;
}

/// The input read through a bounded window: memory stays bounded whatever the file's size. The
/// window starts small and grows (up to its capacity) only while the input has more bytes than
/// it holds, so that a small file costs a small buffer.
class ByteWindow {
 public:
  /// `capacity`: the most bytes Fill can make available at once (the longest message plus
  /// what the reader looks ahead).
  explicit ByteWindow(std::istream& in, std::size_t capacity = std::size_t{1} << 16)
      : in_(in), capacity_(capacity), buf_(std::min<std::size_t>(capacity, 4096)) {}
  /// Makes at least n (<= capacity) bytes available unless the input ends first; returns the
  /// number available.
  std::size_t Fill(std::size_t n) {
    if (end_ - pos_ >= n || eof_) return end_ - pos_;
    if (pos_ > 0) {
      std::memmove(buf_.data(), buf_.data() + pos_, end_ - pos_);
      end_ -= pos_;
      pos_ = 0;
    }
    while (end_ < n && !eof_) {
      if (end_ == buf_.size()) buf_.resize(std::min(capacity_, 2 * buf_.size()));
      in_.read(reinterpret_cast<char*>(buf_.data() + end_),
               static_cast<std::streamsize>(buf_.size() - end_));
      const std::streamsize got = in_.gcount();
      if (got <= 0) eof_ = true;
      end_ += static_cast<std::size_t>(got > 0 ? got : 0);
    }
    return end_ - pos_;
  }
  const unsigned char* data() const { return buf_.data() + pos_; }
  /// Skips n bytes (n <= the bytes available).
  void Skip(std::size_t n) {
    pos_ += n;
    offset_ += static_cast<long long>(n);
  }
  /// Offset in the input of data()[0].
  long long offset() const { return offset_; }

 private:
  std::istream& in_;
  std::size_t capacity_;
  std::vector<unsigned char> buf_;
  std::size_t pos_ = 0, end_ = 0;
  long long offset_ = 0;
  bool eof_ = false;
};

/// A value of a time series (attitude: roll, pitch, yaw in degrees; a height in metres in v[0]).
struct SeriesPoint {
  double time_s;
  double v[3];
};

inline bool SeriesByTime(const SeriesPoint& a, const SeriesPoint& b) { return a.time_s < b.time_s; }

/// Linear interpolation of `series` (sorted by time) at t; with `angles`, along the shorter arc,
/// the third one (yaw) normalised to [0, 360). nullopt outside the series (never extrapolated)
/// or between neighbours more than `max_gap_s` apart (a gap in the log).
inline std::optional<SeriesPoint> InterpolateSeries(const std::vector<SeriesPoint>& series,
                                                    double t, bool angles, double max_gap_s) {
  if (series.empty() || t < series.front().time_s || t > series.back().time_s) {
    return std::nullopt;
  }
  const auto it = std::lower_bound(series.begin(), series.end(), t,
                                   [](const SeriesPoint& p, double x) { return p.time_s < x; });
  SeriesPoint r{t, {}};
  if (it->time_s == t) {
    r = *it;
  } else {
    const SeriesPoint& b = *it;
    const SeriesPoint& a = *(it - 1);
    if (b.time_s - a.time_s > max_gap_s) return std::nullopt;
    const double w = (t - a.time_s) / (b.time_s - a.time_s);
    for (int k = 0; k < 3; ++k) {
      double d = b.v[k] - a.v[k];
      if (angles) d = std::remainder(d, 360.0);
      r.v[k] = a.v[k] + w * d;
    }
  }
  if (angles) {
    r.v[2] = std::fmod(r.v[2], 360.0);
    if (r.v[2] < 0.0) r.v[2] += 360.0;
  }
  return r;
}

}  // namespace aerovo::io_detail
