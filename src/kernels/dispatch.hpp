#pragma once
// One refusal for every kernel entry: the device backend in a binary built without it is a programming error (the
// host checks availability with require_backend first), reported as std::logic_error naming the kernel, never a
// silent no-op. Entries start with require_built(backend, "name"), or call device_not_built in their Device case.
// (Threads without OpenMP needs no refusal: the same bodies then run serially, with the same result.)
#include "kernels/backend.hpp"

namespace capsflow {

// Throws std::logic_error("<kernel>: called with backend 'device' in a build without CAPSFLOW_OFFLOAD ...").
[[noreturn]] void device_not_built(const char* kernel);

inline void require_built(Backend backend, const char* kernel) {
#ifndef CAPSFLOW_HAVE_OFFLOAD
  if (backend == Backend::Device) device_not_built(kernel);
#endif
  (void)backend;
  (void)kernel;
}

}  // namespace capsflow
