#include "aerovo/core/simd.h"

#include <hwy/highway.h>
#include <hwy/targets.h>

#include <atomic>
#include <cctype>
#include <cstdint>
#include <cstdlib>

namespace aerovo {
namespace {

struct EnvMode {
  SimdMode mode = SimdMode::kNative;
  std::string problem;
};

const EnvMode& FromEnvironment() {
  static const EnvMode env = [] {
    EnvMode e;
    const char* v = std::getenv("AEROVO_SIMD");
    if (v != nullptr && !ParseSimdMode(v, &e.mode)) {
      e.problem = std::string("AEROVO_SIMD=") + v +
                  " is not one of native, highway, scalar; using native";
    }
    return e;
  }();
  return env;
}

// -1: not overridden; otherwise a SimdMode.
std::atomic<int> g_override{-1};

std::string Lower(const char* s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

}  // namespace

bool ParseSimdMode(const std::string& value, SimdMode* mode) {
  if (value.empty() || value == "native") {
    *mode = SimdMode::kNative;
  } else if (value == "highway") {
    *mode = SimdMode::kHighway;
  } else if (value == "scalar") {
    *mode = SimdMode::kScalar;
  } else {
    return false;
  }
  return true;
}

SimdMode ActiveSimdMode() {
  const int o = g_override.load(std::memory_order_relaxed);
  return o >= 0 ? static_cast<SimdMode>(o) : FromEnvironment().mode;
}

void SetSimdMode(SimdMode mode) {
  g_override.store(static_cast<int>(mode), std::memory_order_relaxed);
}

std::string SimdEnvironmentProblem() { return FromEnvironment().problem; }

bool CpuHasAvx2Fma() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#else
  return false;
#endif
}

std::string HighwayTargetName() {
  // Highway's target bits: a lower bit is a better target. HWY_TARGETS here is the set every
  // aerovo kernel file is compiled for (same flags).
  const std::int64_t usable = hwy::SupportedTargets() & HWY_TARGETS;
  if (usable == 0) return Lower(hwy::TargetName(HWY_STATIC_TARGET));
  return Lower(hwy::TargetName(usable & -usable));
}

std::string SimdTargetName() {
  switch (ActiveSimdMode()) {
    case SimdMode::kScalar:
      return "scalar";
    case SimdMode::kHighway:
      return HighwayTargetName();
    case SimdMode::kNative:
      break;
  }
#if defined(__x86_64__) || defined(__i386__)
  if (CpuHasAvx2Fma()) return "avx2";
#endif
  return HighwayTargetName();
}

}  // namespace aerovo
