#pragma once
// Bounds on the OpenMP thread count a user may ask for (--threads, [run] threads).
//
// Only what cannot work is refused: more threads than the OpenMP runtime allows (omp_get_thread_limit), than the
// process may create (RLIMIT_NPROC, kernel.threads-max, the cgroup's pids.max) or than the address space can map
// (two mappings per thread stack: vm.max_map_count / 2; half the room left under RLIMIT_AS at one stack each). Past those, libgomp aborts or the process segfaults inside
// the runtime. More threads than CPUs available to the process (affinity mask and cgroup CPU quota) only slows the
// run down: a warning, not an error.
#include <ostream>
#include <string>

namespace capsflow {

struct ThreadLimits {
  long hard = 0;           // the most threads that can be created; 0 when nothing bounds it
  std::string hard_why;    // what sets `hard` ("vm.max_map_count = 65530 allows 32000 thread stacks")
  int cpus = 1;            // CPUs this process may run on (available_cpus(), machine_limits.hpp)
};

ThreadLimits thread_limits();

// Throws InputError "<where>: expected an integer in 0..<hard> (<why>), got <threads>" when `threads` cannot work;
// writes one warning line to `warn` when it exceeds the available CPUs. threads = 0 (the OpenMP default) passes.
void check_thread_count(int threads, const std::string& where, std::ostream& warn);

// Bytes of one OpenMP thread's stack: OMP_STACKSIZE, else glibc's default (the soft stack limit, 8 MiB if unlimited).
double thread_stack_bytes();

// Checks OMP_NUM_THREADS (every nesting level) like --threads: an InputError naming the variable when a count is not
// a positive integer or cannot be created. Called by every command before the first parallel region (libgomp would
// segfault or exit inside the runtime). Oversubscription is not warned about here: --threads and [run] threads do.
void check_thread_environment();

// A stream that discards what it is given (no warning where the threads backend is not used).
std::ostream& null_stream();

}  // namespace capsflow
