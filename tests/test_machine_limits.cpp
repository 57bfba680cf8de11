// What the process may use: CPUs from the affinity mask (and cgroup quota), memory from the rlimits (and cgroup
// and physical memory); the default backend follows the CPUs.
#include <gtest/gtest.h>
#include <sched.h>
#include <sys/resource.h>

#include <thread>

#include "host/base/backend_select.hpp"
#include "host/base/machine_limits.hpp"

namespace capsflow {
namespace {

TEST(MachineLimits, CpusFollowTheAffinityMask) {
  cpu_set_t saved;
  ASSERT_EQ(sched_getaffinity(0, sizeof saved, &saved), 0);
  const int n = available_cpus();
  EXPECT_GE(n, 1);
  EXPECT_LE(n, CPU_COUNT(&saved));
  // Pinned to one CPU: one CPU available, and the default backend is the serial reference.
  cpu_set_t one;
  CPU_ZERO(&one);
  for (int c = 0; c < CPU_SETSIZE; ++c)
    if (CPU_ISSET(c, &saved)) {
      CPU_SET(c, &one);
      break;
    }
  ASSERT_EQ(sched_setaffinity(0, sizeof one, &one), 0);
  const int pinned = available_cpus();
  const Backend b = default_backend();
  ASSERT_EQ(sched_setaffinity(0, sizeof saved, &saved), 0);
  EXPECT_EQ(pinned, 1);
  EXPECT_EQ(b, Backend::Serial);
  if (n > 1 && backend_available(Backend::Threads)) {
    EXPECT_EQ(default_backend(), Backend::Threads);
  }
}

TEST(MachineLimits, MemoryFollowsTheAddressSpaceLimit) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer reserves terabytes of address space: an address-space limit stops it";
#endif
  rlimit saved{};
  ASSERT_EQ(getrlimit(RLIMIT_AS, &saved), 0);
  const MemoryLimit before = available_memory();
  ASSERT_GT(before.bytes, 0u);
  const rlim_t limit = 512ull << 20;
  if (saved.rlim_cur != RLIM_INFINITY && saved.rlim_cur <= limit) GTEST_SKIP() << "RLIMIT_AS already below 512 MiB";
  rlimit lower = saved;
  lower.rlim_cur = limit;
  ASSERT_EQ(setrlimit(RLIMIT_AS, &lower), 0);
  const MemoryLimit limited = available_memory();
  ASSERT_EQ(setrlimit(RLIMIT_AS, &saved), 0);
  EXPECT_EQ(limited.bytes, limit);
  EXPECT_EQ(limited.what, "RLIMIT_AS (ulimit -v)");
}

}  // namespace
}  // namespace capsflow
