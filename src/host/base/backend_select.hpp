#pragma once
// Parsing and availability checks for the execution backends (see kernels/backend.hpp).
#include <string>
#include <string_view>

#include "kernels/backend.hpp"

namespace capsflow {

// "serial" | "threads" | "device"; anything else is an InputError naming `where` (a key or option).
Backend parse_backend(std::string_view name, std::string_view where);
const char* backend_name(Backend b);

// Throws BackendUnavailable with a clear message when `b` cannot run in this binary on this machine
// ('threads' without OpenMP, 'device' without CAPSFLOW_OFFLOAD=ON or without a visible device).
void require_backend(Backend b);
// The same, for a backend that the configuration chose: the message starts with `where`, the key or option that
// chose it ("run.toml: [run] backend: backend 'device' is not available: ...", "--backend: ...").
void require_backend(Backend b, std::string_view where);

// True when require_backend(b) would succeed. For 'device' with a GPU visible it also binds the GPU's primary CUDA
// context to this thread, once (share_cuda_primary_context, device_info.hpp), before any target region opens it.
bool backend_available(Backend b);

// The default of [run] backend: the fastest backend this build and machine offer without asking. 'threads' when
// OpenMP is built in and the process may use more than one CPU (machine_limits.hpp: affinity and cgroup quota),
// else 'serial' (the reference, always selectable). 'device' is never a default: it must be asked for.
Backend default_backend();

// Test-only switch: true when this is an offload build and CAPSFLOW_TEST_DEVICE_HOST_FALLBACK=1. Then 'device' counts
// as available without a device and its target regions run on the OpenMP runtime's host fallback, so the device code
// paths are exercised on a machine without a GPU (ctest sets it; see docs/device.md). Never set in normal runs:
// without it, 'device' with no device is an error, not a silent fallback.
bool device_host_fallback_for_tests();

// Test-only switch: true when this is an offload build and CAPSFLOW_TEST_DEVICE_HOST_MEMORY=1: the device's memory is
// addressable from the host (LLVM's host offload plugin: target regions on the CPU, every mapped array a separate
// copy), so the device global solve runs FFTW on the device's arrays where a GPU runs cuFFT. With it, a CPU checks the
// data movement of the whole device step (a missing map or update reads a stale copy), which the host fallback, whose
// "device" arrays are the host's own, cannot (docs/device.md).
bool device_memory_host_addressable_for_tests();

// Sets the OpenMP thread count for the 'threads' backend. 0: OMP_NUM_THREADS when set, else the CPUs the process
// may use (available_cpus(): OpenMP's own default ignores a cgroup CPU quota and would oversubscribe it).
void set_host_threads(int threads);

}  // namespace capsflow
