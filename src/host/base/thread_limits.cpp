// The implementation of thread_limits.hpp: the bounds on the OpenMP thread count a user may ask for.
#include "host/base/thread_limits.hpp"

#include <sched.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
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

// Bytes mapped by this process now (/proc/self/statm: size in pages).
double mapped_bytes() {
  std::ifstream in("/proc/self/statm");
  double pages = 0.0;
  in >> pages;
  return pages * static_cast<double>(::sysconf(_SC_PAGESIZE));
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
  if (const long pm = number_in("/proc/sys/kernel/pid_max"); pm > 0)  // every thread takes a pid
    take(pm, "kernel.pid_max = " + std::to_string(pm), t);
  // pids.max of the process's cgroup and of the groups above it (v2, then v1's pids controller).
  for (const char* controller : {"", "pids"})
    for (const std::string& dir : cgroup_dirs(controller))
      if (const long pm = number_in((dir + "/pids.max").c_str()); pm > 0)
        take(pm, "the cgroup's pids.max = " + std::to_string(pm), t);
  // Each thread stack is two mappings (stack and guard page); keep room for the process's own mappings.
  if (const long maps = number_in("/proc/sys/vm/max_map_count"); maps > 4096)
    take((maps - 4096) / 2,
         "vm.max_map_count = " + std::to_string(maps) + " (two memory mappings per thread stack)", t);
  // An address-space limit (ulimit -v): libgomp cannot map the stacks and exits with "Thread creation failed". Half
  // of what is left is for stacks; the run's own arrays need the rest.
  if (getrlimit(RLIMIT_AS, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY) {
    const double stack = thread_stack_bytes();
    const double left = static_cast<double>(rl.rlim_cur) - mapped_bytes();
    take(std::max(1L, static_cast<long>(0.5 * left / stack)),
         "the address-space limit (ulimit -v = " + std::to_string(rl.rlim_cur / 1024) + " kB) with " +
             std::to_string(static_cast<long>(stack / (1 << 20))) + " MiB per thread stack",
         t);
  }
  return t;
}

double thread_stack_bytes() {
  // OMP_STACKSIZE: a size with an optional B, K, M or G suffix (K when none), as libgomp reads it.
  if (const char* v = std::getenv("OMP_STACKSIZE"); v && *v) {
    char* end = nullptr;
    const double n = std::strtod(v, &end);
    if (end != v && n > 0) {
      while (*end == ' ') ++end;
      const char u = static_cast<char>(std::toupper(static_cast<unsigned char>(*end)));
      const double scale = u == 'B' ? 1.0 : u == 'M' ? 1048576.0 : u == 'G' ? 1073741824.0 : 1024.0;
      return n * scale;
    }
  }
  // Otherwise glibc's default thread stack: the soft stack limit, 8 MiB when it is unlimited.
  rlimit rl{};
  if (getrlimit(RLIMIT_STACK, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY && rl.rlim_cur > 0)
    return static_cast<double>(rl.rlim_cur);
  return 8.0 * 1048576.0;
}

void check_thread_environment() {
  const char* v = std::getenv("OMP_NUM_THREADS");
  if (!v || !*v) return;
  const std::string text = v;
  const std::string where = "OMP_NUM_THREADS=" + (text.size() > 40 ? text.substr(0, 40) + "..." : text) +
                            " (environment)";
  // A comma-separated list, one count per nesting level; libgomp creates the first level's threads at once.
  const ThreadLimits t = thread_limits();
  std::size_t start = 0;
  while (start <= text.size()) {
    std::size_t comma = text.find(',', start);
    if (comma == std::string::npos) comma = text.size();
    std::string item = text.substr(start, comma - start);
    while (!item.empty() && std::isspace(static_cast<unsigned char>(item.front()))) item.erase(item.begin());
    while (!item.empty() && std::isspace(static_cast<unsigned char>(item.back()))) item.pop_back();
    const bool digits = !item.empty() && std::all_of(item.begin(), item.end(), [](char c) {
      return std::isdigit(static_cast<unsigned char>(c)) != 0;
    });
    if (!digits || item.size() > 9 || std::stol(item) < 1)
      throw InputError(where + ": expected positive integers separated by commas (threads per nesting level), "
                               "got '" + (item.size() > 40 ? item.substr(0, 40) + "..." : item) + "'");
    const long n = std::stol(item);
    if (t.hard > 0 && n > t.hard)
      throw InputError(where + ": expected at most " + std::to_string(t.hard) + " threads (the most this process " +
                       "can create: " + t.hard_why + "), got " + std::to_string(n));
    start = comma + 1;
  }
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
