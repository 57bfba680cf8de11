// The implementation of machine_limits.hpp: what this process may use of the machine.
#include "host/base/machine_limits.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#ifdef __linux__
#include <sched.h>
#include <sys/resource.h>
#include <unistd.h>
#endif

namespace capsflow {
namespace {

std::string first_line(const std::string& path) {
  std::ifstream in(path);
  std::string s;
  if (in) std::getline(in, s);
  return s;
}

}  // namespace

std::vector<std::string> cgroup_dirs(const std::string& controller) {
  std::vector<std::string> dirs;
  std::ifstream in("/proc/self/cgroup");
  std::string line;
  while (std::getline(in, line)) {
    // "hierarchy-ID:controller-list:path"; v2 is "0::path"
    const auto a = line.find(':'), b = line.find(':', a + 1);
    if (a == std::string::npos || b == std::string::npos) continue;
    const std::string list = line.substr(a + 1, b - a - 1), path = line.substr(b + 1);
    bool match = controller.empty() ? list.empty() : false;
    std::stringstream ss(list);
    for (std::string c; std::getline(ss, c, ',');)
      if (c == controller) match = true;
    if (!match) continue;
    const std::string root = controller.empty() ? "/sys/fs/cgroup" : "/sys/fs/cgroup/" + controller;
    std::string p = path;
    for (;;) {
      dirs.push_back(root + (p == "/" ? "" : p));
      if (p.empty() || p == "/") break;
      p = p.substr(0, p.find_last_of('/'));
      if (p.empty()) p = "/";
    }
  }
  return dirs;
}

int available_cpus() {
  int n = 0;
#ifdef __linux__
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) == 0) n = CPU_COUNT(&set);
#endif
  if (n <= 0) n = static_cast<int>(std::thread::hardware_concurrency());
  if (n <= 0) n = 1;
  double quota = 0.0;  // CPUs the cgroup quota allows (0: no quota)
  auto take = [&](double q) {
    if (q > 0.0) quota = quota > 0.0 ? std::min(quota, q) : q;
  };
  for (const std::string& d : cgroup_dirs("")) {  // v2: "max 100000" or "200000 100000"
    std::istringstream s(first_line(d + "/cpu.max"));
    std::string q;
    double period = 0.0;
    if (s >> q >> period && q != "max" && period > 0.0) take(std::stod(q) / period);
  }
  for (const std::string& d : cgroup_dirs("cpu")) {  // v1: quota -1 means none
    const std::string q = first_line(d + "/cpu.cfs_quota_us"), p = first_line(d + "/cpu.cfs_period_us");
    if (!q.empty() && !p.empty() && std::stod(q) > 0.0 && std::stod(p) > 0.0) take(std::stod(q) / std::stod(p));
  }
  if (quota > 0.0) n = std::min(n, std::max(1, static_cast<int>(std::ceil(quota - 1e-9))));
  return n;
}

MemoryLimit available_memory() {
  MemoryLimit m;
  auto take = [&](std::uint64_t b, const std::string& what) {
    if (b > 0 && (m.bytes == 0 || b < m.bytes)) {
      m.bytes = b;
      m.what = what;
    }
  };
#ifdef __linux__
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
  if (pages > 0 && page > 0)
    take(static_cast<std::uint64_t>(pages) * static_cast<std::uint64_t>(page), "physical memory");
  // A cgroup without a limit reads "max" (v2) or a huge number (v1, ~2^63): both above physical memory.
  auto number = [](const std::string& s) -> std::uint64_t {
    if (s.empty() || s == "max") return 0;
    try {
      return static_cast<std::uint64_t>(std::stoull(s));
    } catch (...) {
      return 0;
    }
  };
  for (const std::string& d : cgroup_dirs("")) take(number(first_line(d + "/memory.max")), "cgroup memory.max");
  for (const std::string& d : cgroup_dirs("memory"))
    take(number(first_line(d + "/memory.limit_in_bytes")), "cgroup memory.limit_in_bytes");
  for (auto [res, name] : {std::pair<int, const char*>{RLIMIT_AS, "RLIMIT_AS (ulimit -v)"},
                           std::pair<int, const char*>{RLIMIT_DATA, "RLIMIT_DATA (ulimit -d)"}}) {
    rlimit r{};
    if (getrlimit(res, &r) == 0 && r.rlim_cur != RLIM_INFINITY) take(static_cast<std::uint64_t>(r.rlim_cur), name);
  }
#endif
  return m;
}

}  // namespace capsflow
