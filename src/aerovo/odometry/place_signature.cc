#include "aerovo/odometry/place_signature.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "aerovo/core/error.h"

namespace aerovo {

namespace {

// SplitMix64 (Steele, Lea & Flood, "Fast splittable pseudorandom number generators", OOPSLA
// 2014) of a counter: portable, the same numbers on every standard library.
std::uint64_t Mix(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

// A standard normal number k of the stream `seed` (Box-Muller on two uniforms in (0, 1]).
double NormalOf(std::uint64_t seed, std::uint64_t k) {
  const double u1 = (static_cast<double>(Mix(seed ^ Mix(2 * k)) >> 11) + 1.0) * 0x1.0p-53;
  const double u2 = static_cast<double>(Mix(seed ^ Mix(2 * k + 1)) >> 11) * 0x1.0p-53;
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * 3.14159265358979323846 * u2);
}

}  // namespace

DescriptorQuantizer::DescriptorQuantizer(const FeatureSet& first, int bits, std::uint64_t seed)
    : bits_(bits), size_(first.descriptor_size) {
  if (bits < 1 || bits > 24) {
    throw InvalidArgument("DescriptorQuantizer: bits must be in [1, 24], got " +
                          std::to_string(bits));
  }
  if (size_ < 1) {
    throw InvalidArgument("DescriptorQuantizer: the descriptor size must be positive, got " +
                          std::to_string(size_));
  }
  const std::size_t n = static_cast<std::size_t>(bits_) * static_cast<std::size_t>(size_);
  directions_.resize(n);
  const std::uint64_t stream = Mix(seed ^ 0x5eed0f91ac35ULL);
  for (std::size_t k = 0; k < n; ++k) directions_[k] = static_cast<float>(NormalOf(stream, k));
  thresholds_.assign(static_cast<std::size_t>(bits_), 0.f);
  if (first.empty()) return;
  std::vector<float> proj(first.size());
  for (int b = 0; b < bits_; ++b) {
    const float* dir = directions_.data() + static_cast<std::size_t>(b) * size_;
    for (std::size_t i = 0; i < first.size(); ++i) {
      const float* d = first.descriptor(i);
      float s = 0.f;
      for (int j = 0; j < size_; ++j) s += dir[j] * d[j];
      proj[i] = s;
    }
    const auto mid = proj.begin() + static_cast<std::ptrdiff_t>(proj.size() / 2);
    std::nth_element(proj.begin(), mid, proj.end());
    thresholds_[static_cast<std::size_t>(b)] = *mid;
  }
}

std::uint32_t DescriptorQuantizer::Word(const float* descriptor) const {
  std::uint32_t word = 0;
  for (int b = 0; b < bits_; ++b) {
    const float* dir = directions_.data() + static_cast<std::size_t>(b) * size_;
    float s = 0.f;
    for (int j = 0; j < size_; ++j) s += dir[j] * descriptor[j];
    word |= (s > thresholds_[static_cast<std::size_t>(b)] ? 1u : 0u) << b;
  }
  return word;
}

PlaceSignature SignatureOf(const DescriptorQuantizer& quantizer, const FeatureSet& features) {
  if (!features.empty() && features.descriptor_size != quantizer.descriptor_size()) {
    throw InvalidArgument("SignatureOf: descriptors of " +
                          std::to_string(features.descriptor_size) +
                          " values, the quantiser's are of " +
                          std::to_string(quantizer.descriptor_size()));
  }
  std::vector<std::uint32_t> all(features.size());
  for (std::size_t i = 0; i < features.size(); ++i) all[i] = quantizer.Word(features.descriptor(i));
  std::sort(all.begin(), all.end());
  PlaceSignature s;
  double norm2 = 0.0;
  for (std::size_t i = 0; i < all.size();) {
    std::size_t j = i;
    while (j < all.size() && all[j] == all[i]) ++j;
    s.words.push_back(all[i]);
    s.weights.push_back(static_cast<float>(std::sqrt(static_cast<double>(j - i))));
    norm2 += static_cast<double>(j - i);
    i = j;
  }
  if (norm2 <= 0.0) return s;
  const float inv = static_cast<float>(1.0 / std::sqrt(norm2));
  for (float& v : s.weights) v *= inv;
  return s;
}

double Similarity(const PlaceSignature& a, const PlaceSignature& b) {
  double dot = 0.0;
  std::size_t i = 0, j = 0;
  while (i < a.words.size() && j < b.words.size()) {
    if (a.words[i] < b.words[j]) {
      ++i;
    } else if (b.words[j] < a.words[i]) {
      ++j;
    } else {
      dot += static_cast<double>(a.weights[i++]) * b.weights[j++];
    }
  }
  return std::clamp(dot, 0.0, 1.0);
}

}  // namespace aerovo
