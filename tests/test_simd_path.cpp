// The host vector path's rule (kernels/simd_path.hpp): the CPU's best capped by CAPSFLOW_SIMD / CAPSFLOW_NO_AVX512,
// and this process's path as the environment it runs in asks (tools/simd_paths.sh runs the vector-sensitive suites
// once per path the CPU has; this test prints which path the process took, so CI's output shows it).
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "kernels/simd_path.hpp"

namespace capsflow {
namespace {

constexpr SimdPath kAll[] = {SimdPath::Portable, SimdPath::Avx2, SimdPath::Avx512};

TEST(SimdPath, TheEnvironmentCapsTheCpusBest) {
  for (SimdPath cpu : kAll) {
    EXPECT_EQ(simd_path_for(cpu, nullptr, nullptr), cpu);
    EXPECT_EQ(simd_path_for(cpu, "", ""), cpu);
    EXPECT_EQ(simd_path_for(cpu, "avx512", nullptr), cpu);  // never above what the CPU has
    EXPECT_EQ(simd_path_for(cpu, "portable", nullptr), SimdPath::Portable);
    EXPECT_EQ(simd_path_for(cpu, "bogus", nullptr), cpu);  // refused by the command line before this matters
  }
  EXPECT_EQ(simd_path_for(SimdPath::Avx512, "avx2", nullptr), SimdPath::Avx2);
  EXPECT_EQ(simd_path_for(SimdPath::Avx2, "avx2", nullptr), SimdPath::Avx2);
  EXPECT_EQ(simd_path_for(SimdPath::Portable, "avx2", nullptr), SimdPath::Portable);
  // CAPSFLOW_NO_AVX512 (any non-empty value) is a cap at avx2, under a lower CAPSFLOW_SIMD too.
  EXPECT_EQ(simd_path_for(SimdPath::Avx512, nullptr, "1"), SimdPath::Avx2);
  EXPECT_EQ(simd_path_for(SimdPath::Avx512, "avx512", "1"), SimdPath::Avx2);
  EXPECT_EQ(simd_path_for(SimdPath::Avx512, "portable", "1"), SimdPath::Portable);
  EXPECT_EQ(simd_path_for(SimdPath::Avx2, nullptr, "1"), SimdPath::Avx2);
  for (SimdPath p : kAll) EXPECT_STRNE(simd_path_name(p), "");
  EXPECT_STREQ(simd_path_name(SimdPath::Avx512), "avx512");
  EXPECT_STREQ(simd_path_name(SimdPath::Avx2), "avx2");
  EXPECT_STREQ(simd_path_name(SimdPath::Portable), "portable");
}

// The path of this process against the variables it was started with, parsed here independently of the rule.
TEST(SimdPath, ThisProcessTakesThePathItsEnvironmentAsks) {
  const char* v = std::getenv("CAPSFLOW_SIMD");
  const char* no512 = std::getenv("CAPSFLOW_NO_AVX512");
  int cap = 2;
  if (v != nullptr && std::strcmp(v, "avx2") == 0) cap = 1;
  if (v != nullptr && std::strcmp(v, "portable") == 0) cap = 0;
  if (no512 != nullptr && *no512 != '\0' && cap > 1) cap = 1;
  const int cpu = static_cast<int>(cpu_simd_path());
  const int expected = cpu < cap ? cpu : cap;
  std::printf("  vector path: %s (CPU's best %s; CAPSFLOW_SIMD=%s)\n", simd_path_name(host_simd_path()),
              simd_path_name(cpu_simd_path()), v != nullptr ? v : "unset");
  EXPECT_EQ(static_cast<int>(host_simd_path()), expected);
  const bool named = v == nullptr || *v == '\0' || std::strcmp(v, "portable") == 0 || std::strcmp(v, "avx2") == 0 ||
                     std::strcmp(v, "avx512") == 0;
  EXPECT_EQ(simd_environment_problem().empty(), named);
}

}  // namespace
}  // namespace capsflow
