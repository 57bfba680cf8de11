#pragma once
// What this process may use of the machine: CPUs (affinity mask, cgroup CPU quota) and memory (physical memory,
// cgroup memory limit, address-space rlimit). Read from Linux's /proc and /sys; elsewhere the portable answers
// (std::thread::hardware_concurrency, no memory bound).
//
// Used for the defaults ([run] backend and threads) and for the input check that refuses a grid which cannot fit
// (config_estimate.hpp), so both see the limits a container or a batch scheduler imposes, not the host's.
#include <cstdint>
#include <string>
#include <vector>

namespace capsflow {

// CPUs the process may run on: the affinity mask, capped by a cgroup CPU quota (v2 cpu.max, v1
// cpu.cfs_quota_us / cpu.cfs_period_us, rounded up). At least 1.
int available_cpus();

// The cgroup directories of this process for a controller ("" for v2, else "cpu", "memory", "pids"), innermost
// first, up to the mount root: a limit on any of them applies.
std::vector<std::string> cgroup_dirs(const std::string& controller);

struct MemoryLimit {
  std::uint64_t bytes = 0;  // the smallest of the limits found; 0: none found
  std::string what;         // which one binds: "physical memory", "cgroup memory.max", "RLIMIT_AS", ...
};
// The memory the process may use: min(physical memory, cgroup limit of its own group and the groups above it,
// RLIMIT_AS, RLIMIT_DATA).
MemoryLimit available_memory();

}  // namespace capsflow
