#include "host/base/thread_limits.hpp"

#include <sched.h>
#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>

#include "host/base/errors.hpp"
#include "host/base/machine_limits.hpp"

#ifdef CAPSFLOW_HAVE_OPENMP
#include <omp.h>
#endif

namespace capsflow {

namespace {

// The first whitespace-separated word of a file, or "" when it cannot be read.
std::string first_word(const char* path) {
  std::ifstream in(path);
  std::string w;
  in >> w;
  return w;
}

long number_in(const char* path) {
  const std::string w = first_word(path);
  if (w.empty() || w == "max") return 0;
  try {
    return std::stol(w);
  } catch (...) {
    return 0;
  }
}

void take(long value, const std::string& why, ThreadLimits& t) {
  if (value > 0 && (t.hard == 0 || value < t.hard)) {
    t.hard = value;
    t.hard_why = why;
  }
}

}  // namespace

ThreadLimits thread_limits() {
  ThreadLimits t;
  t.cpus = available_cpus();
#ifdef CAPSFLOW_HAVE_OPENMP
  const int omp_limit = omp_get_thread_limit();
  if (omp_limit > 0 && omp_limit < (1 << 30)) take(omp_limit, "the OpenMP thread limit (OMP_THREAD_LIMIT)", t);
#endif
  rlimit rl{};
  if (getrlimit(RLIMIT_NPROC, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY)
    take(static_cast<long>(rl.rlim_cur), "the process limit (ulimit -u = " + std::to_string(rl.rlim_cur) + ")", t);
  if (const long tm = number_in("/proc/sys/kernel/threads-max"); tm > 0)
    take(tm, "kernel.threads-max = " + std::to_string(tm), t);
  // pids.max of the process's cgroup and of the groups above it (v2, then v1's pids controller).
  for (const char* controller : {"", "pids"})
    for (const std::string& dir : cgroup_dirs(controller))
      if (const long pm = number_in((dir + "/pids.max").c_str()); pm > 0)
        take(pm, "the cgroup's pids.max = " + std::to_string(pm), t);
  // Each thread stack is two mappings (stack and guard page); keep room for the process's own mappings.
  if (const long maps = number_in("/proc/sys/vm/max_map_count"); maps > 4096)
    take((maps - 4096) / 2,
         "vm.max_map_count = " + std::to_string(maps) + " (two memory mappings per thread stack)", t);
  return t;
}

void check_thread_count(int threads, const std::string& where, std::ostream& warn) {
  if (threads < 0) throw InputError(where + ": expected an integer >= 0 (0: the OpenMP default), got " +
                                    std::to_string(threads));
  if (threads == 0) return;
  const ThreadLimits t = thread_limits();
  if (t.hard > 0 && threads > t.hard)
    throw InputError(where + ": expected an integer in 0.." + std::to_string(t.hard) + " (the most threads this " +
                     "process can create: " + t.hard_why + "), got " + std::to_string(threads));
  if (threads > t.cpus)
    warn << "capsflow: warning: " << where << " = " << threads << " is more than the " << t.cpus << " CPU"
         << (t.cpus == 1 ? "" : "s") << " available to this process (affinity and cgroup quota): the threads "
         << "share them and the run is slower, not faster\n";
}

std::ostream& null_stream() {
  static std::ostream sink(nullptr);  // no buffer: every write is dropped
  return sink;
}

}  // namespace capsflow
