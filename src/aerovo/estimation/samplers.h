// Minimal-sample generators for the RANSAC loop (aerovo/estimation/ransac.h), as policies.
//
// Sampler interface:
//   void Reset(std::uint64_t seed, int num_points, int sample_size, const float* quality);
//       starts a new estimation over num_points correspondences; `quality` (may be null) holds
//       one value per correspondence, LOWER = BETTER (e.g. the descriptor SSD of the match);
//   void Draw(int* indices);
//       writes sample_size distinct indices in [0, num_points).
// Determinism: the sequence depends only on (seed, num_points, sample_size, quality); the
// generator is std::mt19937_64 (its output is fixed by the C++ standard) with our own
// bounded-integer mapping, so the same seed gives the same samples on every platform.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

namespace aerovo {

/// Which sampler the run-time dispatch (EstimateTransform, the correspondence stage) uses.
enum class SamplerKind {
  kUniform,  ///< Uniform random minimal samples (classic RANSAC / MATLAB MSAC).
  kProsac,   ///< PROSAC: samples drawn from progressively larger sets of the best matches.
};

/// Uniform integer in [0, n), n >= 1: Lemire's multiply-shift with rejection (unbiased).
std::uint32_t UniformBelow(std::mt19937_64& rng, std::uint32_t n);

/// Uniform random minimal samples without repetition (quality is ignored).
class UniformSampler {
 public:
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

}  // namespace aerovo
