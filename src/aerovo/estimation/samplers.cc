#include "aerovo/estimation/samplers.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>

#include "aerovo/core/error.h"

namespace aerovo {

const char* ToString(SamplerKind sampler) {
  switch (sampler) {
#define AEROVO_SAMPLER_NAME(e, T) \
  case SamplerKind::e:            \
    return T::kName;
    AEROVO_SAMPLERS(AEROVO_SAMPLER_NAME)
#undef AEROVO_SAMPLER_NAME
  }
  return "unknown";
}

SamplerKind ParseSamplerKind(const char* name) {
  const std::string s = name == nullptr ? "" : name;
  std::string expected;
  for (std::size_t k = 0; k < kNumSamplerKinds; ++k) {
    if (s == ToString(kAllSamplerKinds[k])) return kAllSamplerKinds[k];
    expected += k == 0 ? "" : (k + 1 == kNumSamplerKinds ? " or " : ", ");
    expected += ToString(kAllSamplerKinds[k]);
  }
  throw InvalidArgument("unknown sampler '" + s + "' (expected " + expected + ")");
}

std::uint32_t UniformBelow(std::mt19937_64& rng, std::uint32_t n) {
  // Lemire, "Fast random integer generation in an interval", ACM TOMACS 2019. The standard
  // library's distributions are implementation-defined; this mapping is not.
  std::uint64_t x = rng() >> 32;
  std::uint64_t m = x * n;
  std::uint32_t low = static_cast<std::uint32_t>(m);
  if (low < n) {
    const std::uint32_t threshold = static_cast<std::uint32_t>(-n) % n;
    while (low < threshold) {
      x = rng() >> 32;
      m = x * n;
      low = static_cast<std::uint32_t>(m);
    }
  }
  return static_cast<std::uint32_t>(m >> 32);
}

namespace {

// `count` distinct values in [0, n) (count is a minimal sample size: tiny, so rejection of
// repeats is cheaper than any shuffle).
void DistinctBelow(std::mt19937_64& rng, int n, int count, int* out) {
  for (int k = 0; k < count; ++k) {
    for (;;) {
      const int v = static_cast<int>(UniformBelow(rng, static_cast<std::uint32_t>(n)));
      bool repeated = false;
      for (int j = 0; j < k; ++j) repeated |= (out[j] == v);
      if (!repeated) {
        out[k] = v;
        break;
      }
    }
  }
}

}  // namespace

void UniformSampler::Reset(std::uint64_t seed, int num_points, int sample_size, const float*) {
  rng_.seed(seed);
  num_points_ = num_points;
  sample_size_ = sample_size;
}

void UniformSampler::Draw(int* indices) { DistinctBelow(rng_, num_points_, sample_size_, indices); }

void ProsacSampler::Reset(std::uint64_t seed, int num_points, int sample_size,
                          const float* quality) {
  rng_.seed(seed);
  num_points_ = num_points;
  sample_size_ = sample_size;
  order_.resize(static_cast<std::size_t>(num_points));
  std::iota(order_.begin(), order_.end(), 0);
  if (quality != nullptr) {
    std::stable_sort(order_.begin(), order_.end(),
                     [quality](int a, int b) { return quality[a] < quality[b]; });
  }
  n_ = sample_size;
  t_ = 0;
  // T_m = T_N * prod_{i<m} (m - i) / (N - i): expected number of samples drawn from the top
  // m among T_N uniform samples over all N.
  t_n_ = kGrowthMaxSamples;
  for (int i = 0; i < sample_size; ++i) {
    t_n_ *= static_cast<double>(sample_size - i) / static_cast<double>(num_points - i);
  }
  t_n_prime_ = 1;
}

void ProsacSampler::DrawFromFirst(int n, int count, int* out) {
  DistinctBelow(rng_, n, count, out);
  for (int k = 0; k < count; ++k) out[k] = order_[static_cast<std::size_t>(out[k])];
}

void ProsacSampler::Draw(int* indices) {
  ++t_;
  if (t_ > t_n_prime_ && n_ < num_points_) {
    const double t_next = t_n_ * (n_ + 1) / static_cast<double>(n_ + 1 - sample_size_);
    t_n_prime_ += static_cast<std::int64_t>(std::ceil(t_next - t_n_));
    t_n_ = t_next;
    ++n_;
  }
  if (t_n_prime_ < t_) {
    DrawFromFirst(n_, sample_size_, indices);
  } else {
    // The n-th best correspondence is always in the sample; the rest come from the top n-1.
    DrawFromFirst(n_ - 1, sample_size_ - 1, indices);
    indices[sample_size_ - 1] = order_[static_cast<std::size_t>(n_ - 1)];
  }
}

}  // namespace aerovo
