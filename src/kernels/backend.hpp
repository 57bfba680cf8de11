#pragma once
// Execution backends of the flat-array kernels.
//
//  serial  - the reference: plain deterministic loops, one thread.
//  threads - OpenMP parallel loops on the host (race-free, no atomics).
//  device  - OpenMP target offload (CAPSFLOW_OFFLOAD=ON builds only); atomics where sources scatter.
//
// A backend is chosen once at run time. Kernels take it as a plain argument and never fall back silently:
// the host checks availability (require_backend) before any kernel runs.
namespace capsflow {

enum class Backend { Serial, Threads, Device };

// True when this binary contains target regions (built with CAPSFLOW_OFFLOAD=ON).
bool device_backend_built();
// Number of offload devices the OpenMP runtime sees (0 when not built with offload).
int device_count();
// Threads the 'threads' backend will use (omp_get_max_threads; 1 without OpenMP).
int host_thread_count();

}  // namespace capsflow
