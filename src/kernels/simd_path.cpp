// The host's vector path (simd_path.hpp): the CPU's best path capped by CAPSFLOW_SIMD / CAPSFLOW_NO_AVX512.
#include "kernels/simd_path.hpp"

#include <cstdlib>
#include <cstring>

namespace capsflow {

namespace {

// -1: not a path name.
int parse_path(const char* v) {
  if (std::strcmp(v, "portable") == 0) return static_cast<int>(SimdPath::Portable);
  if (std::strcmp(v, "avx2") == 0) return static_cast<int>(SimdPath::Avx2);
  if (std::strcmp(v, "avx512") == 0) return static_cast<int>(SimdPath::Avx512);
  return -1;
}

}  // namespace

SimdPath cpu_simd_path() {
  // The vector loops exist only in x86-64 host builds (offload builds keep the portable loops that the device
  // copies mirror).
#if defined(__x86_64__) && !defined(CAPSFLOW_HAVE_OFFLOAD) && (defined(__GNUC__) || defined(__clang__))
  static const SimdPath best = [] {
    if (__builtin_cpu_supports("avx512f")) return SimdPath::Avx512;
    if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) return SimdPath::Avx2;
    return SimdPath::Portable;
  }();
  return best;
#else
  return SimdPath::Portable;
#endif
}

SimdPath simd_path_for(SimdPath cpu, const char* simd_env, const char* no_avx512_env) {
  int cap = static_cast<int>(SimdPath::Avx512);
  if (simd_env != nullptr && *simd_env != '\0' && parse_path(simd_env) >= 0) cap = parse_path(simd_env);
  if (no_avx512_env != nullptr && *no_avx512_env != '\0' && cap > static_cast<int>(SimdPath::Avx2))
    cap = static_cast<int>(SimdPath::Avx2);
  return static_cast<int>(cpu) < cap ? cpu : static_cast<SimdPath>(cap);
}

SimdPath host_simd_path() {
  static const SimdPath path =
      simd_path_for(cpu_simd_path(), std::getenv("CAPSFLOW_SIMD"), std::getenv("CAPSFLOW_NO_AVX512"));
  return path;
}

const char* simd_path_name(SimdPath p) {
  switch (p) {
    case SimdPath::Avx512: return "avx512";
    case SimdPath::Avx2: return "avx2";
    case SimdPath::Portable: break;
  }
  return "portable";
}

std::string simd_environment_problem() {
  const char* v = std::getenv("CAPSFLOW_SIMD");
  if (v == nullptr || *v == '\0' || parse_path(v) >= 0) return {};
  return std::string("CAPSFLOW_SIMD: expected portable, avx2 or avx512 (the highest vector path to use), got '") + v +
         "'";
}

}  // namespace capsflow
