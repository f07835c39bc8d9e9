// Which SIMD kernels aerovo's hot loops (SURF's Hessian rows, the matcher's distance kernels)
// run: chosen once per process from the environment variable AEROVO_SIMD, overridable by tests.
#pragma once

#include <string>

namespace aerovo {

/// Kernel family. Every family computes the same keypoints and matches; floating-point sums
/// may differ in the last bits where a family fuses multiply-adds (see each kernel's header).
enum class SimdMode {
  /// Best available on this CPU: on x86 with AVX2+FMA the hand-written AVX2 kernels (measured
  /// faster than the Highway ones, BENCHMARKS.md "Portable SIMD"), on x86 without AVX2 the
  /// SSE4 kernels, elsewhere (aarch64: NEON, SVE, SVE2) Google Highway's best target.
  kNative,
  /// Google Highway's kernels on the best target Highway supports on this CPU, even where
  /// hand-written ones exist (to test and benchmark them on x86).
  kHighway,
  /// aerovo's portable C++ loops, no intrinsics (the compiler may still auto-vectorise them at
  /// the build's baseline instruction set): the reference every SIMD kernel is tested against.
  kScalar,
};

/// AEROVO_SIMD value -> mode: "native" (or unset / empty), "highway", "scalar". Returns false
/// (and leaves *mode unchanged) for any other value.
bool ParseSimdMode(const std::string& value, SimdMode* mode);

/// The mode in effect: SetSimdMode's, else AEROVO_SIMD's (read at the first call; an unknown
/// value selects kNative and is reported by SimdEnvironmentProblem()).
SimdMode ActiveSimdMode();

/// Overrides the mode for the rest of the process (tests, benchmarks). Kernels consult the mode
/// at every call, so this takes effect immediately; not to be called while kernels run on other
/// threads.
void SetSimdMode(SimdMode mode);

/// Empty, or a sentence naming an unusable AEROVO_SIMD value (for the CLI to print).
std::string SimdEnvironmentProblem();

/// Name of the instruction set the active mode's kernels use on this CPU: "scalar", "avx2",
/// "sse4" (hand-written x86 kernels) or Highway's target name in lower case ("avx3", "avx2",
/// "sse4", "neon", "sve", "sve2", "sve_256", "sve2_128", "emu128").
std::string SimdTargetName();

/// Highway's best target on this CPU among those aerovo was compiled for, lower case (as above).
std::string HighwayTargetName();

/// True on x86 CPUs with AVX2 and FMA (where kNative selects the hand-written AVX2 kernels).
bool CpuHasAvx2Fma();

}  // namespace aerovo
