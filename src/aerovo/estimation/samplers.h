// Minimal-sample generators for the RANSAC loop (aerovo/estimation/ransac.h), as policies.
//
// Sampler interface:
//   static constexpr const char* kName;
//       lower-case name for logs, the CLI and config files (ToString / ParseSamplerKind);
//   default constructor (the run-time dispatch makes one per call);
//   void Reset(std::uint64_t seed, int num_points, int sample_size, const float* quality);
//       starts a new estimation over num_points correspondences; `quality` (may be null) holds
//       one value per correspondence, LOWER = BETTER (e.g. the descriptor SSD of the match);
//   void Draw(int* indices);
//       writes sample_size distinct indices in [0, num_points).
// Determinism: the sequence depends only on (seed, num_points, sample_size, quality); the
// generator is std::mt19937_64 (its output is fixed by the C++ standard) with our own
// bounded-integer mapping, so the same seed gives the same samples on every platform.
//
// How to add a sampler: write its class with the interface above (declaration here, definitions
// in samplers.cc) and add one entry X(kName, Class) to AEROVO_SAMPLERS. That generates the
// enumerator SamplerKind::kName, ToString / ParseSamplerKind, kAllSamplerKinds and the run-time
// dispatch VisitSampler (used by EstimateTransform in ransac.cc).
#pragma once

#include <cstddef>
#include <cstdint>
#include <iterator>
#include <random>
#include <vector>

namespace aerovo {

/// THE list of samplers: X(enumerator, sampler class), in the order of the enum.
// clang-format off
#define AEROVO_SAMPLERS(X)                                                                       \
  X(kUniform, UniformSampler) /* Uniform minimal samples (classic RANSAC, MATLAB's MSAC). */    \
  X(kProsac, ProsacSampler)   /* PROSAC: progressively larger sets of the best matches. */
// clang-format on

/// Which sampler the run-time dispatch (EstimateTransform, the correspondence stage) uses.
enum class SamplerKind {
#define AEROVO_SAMPLER_ENUMERATOR(e, T) e,
  AEROVO_SAMPLERS(AEROVO_SAMPLER_ENUMERATOR)
#undef AEROVO_SAMPLER_ENUMERATOR
};

/// Every SamplerKind, in enum order: the choices of a CLI flag or config key (with ToString).
inline constexpr SamplerKind kAllSamplerKinds[] = {
#define AEROVO_SAMPLER_VALUE(e, T) SamplerKind::e,
    AEROVO_SAMPLERS(AEROVO_SAMPLER_VALUE)
#undef AEROVO_SAMPLER_VALUE
};
inline constexpr std::size_t kNumSamplerKinds = std::size(kAllSamplerKinds);

/// The sampler's kName: "uniform", "prosac".
const char* ToString(SamplerKind sampler);
/// Inverse of ToString; throws InvalidArgument naming the accepted values.
SamplerKind ParseSamplerKind(const char* name);

/// Uniform integer in [0, n), n >= 1: Lemire's multiply-shift with rejection (unbiased).
std::uint32_t UniformBelow(std::mt19937_64& rng, std::uint32_t n);

/// Uniform random minimal samples without repetition (quality is ignored).
class UniformSampler {
 public:
  static constexpr const char* kName = "uniform";

  void Reset(std::uint64_t seed, int num_points, int sample_size, const float* quality);
  void Draw(int* indices);

 private:
  std::mt19937_64 rng_;
  int num_points_ = 0;
  int sample_size_ = 0;
};

/// PROSAC (Chum & Matas, "Matching with PROSAC - progressive sample consensus", CVPR 2005):
/// correspondences are ranked by quality; sample t is drawn from the best n(t) of them, n(t)
/// growing by the paper's growth function from sample_size to num_points (T_N = 200000, the
/// paper's value), so good matches are tried first while the draw converges to uniform
/// sampling. Without quality values the given order is the ranking.
class ProsacSampler {
 public:
  /// T_N of the paper: the number of samples after which PROSAC would reach uniform sampling.
  static constexpr double kGrowthMaxSamples = 200000.0;
  static constexpr const char* kName = "prosac";

  void Reset(std::uint64_t seed, int num_points, int sample_size, const float* quality);
  void Draw(int* indices);

 private:
  void DrawFromFirst(int n, int count, int* out);

  std::mt19937_64 rng_;
  std::vector<int> order_;  // Correspondence indices, best first.
  int num_points_ = 0;
  int sample_size_ = 0;
  int n_ = 0;                   // Current size of the sampled top set.
  std::int64_t t_ = 0;          // Samples drawn so far.
  double t_n_ = 0.0;            // T_n of the paper (real-valued).
  std::int64_t t_n_prime_ = 0;  // T'_n of the paper (integer growth schedule).
};

/// Run-time dispatch: default-constructs the sampler of `kind`, calls f(sampler) with it (an
/// lvalue of the static type) and returns what f returns. A value outside the enum gets the
/// uniform sampler.
template <class F>
decltype(auto) VisitSampler(SamplerKind kind, F&& f) {
  switch (kind) {
#define AEROVO_SAMPLER_CASE(e, T) \
  case SamplerKind::e: {          \
    T sampler;                    \
    return f(sampler);            \
  }
    AEROVO_SAMPLERS(AEROVO_SAMPLER_CASE)
#undef AEROVO_SAMPLER_CASE
  }
  UniformSampler sampler;
  return f(sampler);
}

}  // namespace aerovo
