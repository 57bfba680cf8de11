// The implementation of backend_select.hpp: parsing and availability checks of the execution backends.
#include "host/base/backend_select.hpp"

#include <cstdlib>
#include <string>
#include <string_view>

#include "host/base/device_info.hpp"
#include "host/base/errors.hpp"
#include "host/base/machine_limits.hpp"

#ifdef CAPSFLOW_HAVE_OPENMP
#include <omp.h>
#endif

namespace capsflow {

Backend parse_backend(std::string_view name, std::string_view where) {
  if (name == "serial") return Backend::Serial;
  if (name == "threads") return Backend::Threads;
  if (name == "device") return Backend::Device;
  throw InputError(std::string(where) + ": unknown backend '" + std::string(name) +
                   "', expected \"serial\", \"threads\" or \"device\"");
}

const char* backend_name(Backend b) {
  switch (b) {
    case Backend::Serial: return "serial";
    case Backend::Threads: return "threads";
    case Backend::Device: return "device";
  }
  return "?";
}

bool backend_available(Backend b) {
  switch (b) {
    case Backend::Serial: return true;
    case Backend::Threads:
#ifdef CAPSFLOW_HAVE_OPENMP
      return true;
#else
      return false;
#endif
    case Backend::Device:
      if (!device_backend_built()) return false;
      if (device_count() > 0) {
        share_cuda_primary_context();  // before the OpenMP runtime opens the device (device_info.hpp)
        return true;
      }
      return device_host_fallback_for_tests();
  }
  return false;
}

bool device_host_fallback_for_tests() {
  if (!device_backend_built()) return false;
  const char* v = std::getenv("CAPSFLOW_TEST_DEVICE_HOST_FALLBACK");
  return v != nullptr && std::string_view(v) == "1";
}

bool device_memory_host_addressable_for_tests() {
  if (!device_backend_built()) return false;
  const char* v = std::getenv("CAPSFLOW_TEST_DEVICE_HOST_MEMORY");
  return v != nullptr && std::string_view(v) == "1";
}

void require_backend(Backend b) {
  if (backend_available(b)) return;
  if (b == Backend::Threads)
    throw BackendUnavailable("backend 'threads' is not available: this binary was built with CAPSFLOW_OPENMP=OFF");
  if (!device_backend_built())
    throw BackendUnavailable(
        "backend 'device' is not available: this binary was built without CAPSFLOW_OFFLOAD=ON "
        "(see docs/performance.md for the offload build)");
  throw BackendUnavailable(
      "backend 'device' is not available: built with offload, but the OpenMP runtime sees no device "
      "(omp_get_num_devices() = 0; no GPU, no CUDA driver, or CUDA_VISIBLE_DEVICES hides it)");
}

void require_backend(Backend b, std::string_view where) {
  try {
    require_backend(b);
  } catch (const BackendUnavailable& e) {
    throw BackendUnavailable(std::string(where) + ": " + e.what());
  }
}

Backend default_backend() {
  return backend_available(Backend::Threads) && available_cpus() > 1 ? Backend::Threads : Backend::Serial;
}

void set_host_threads(int threads) {
#ifdef CAPSFLOW_HAVE_OPENMP
  if (threads > 0) {
    omp_set_num_threads(threads);
  } else {
    const char* env = std::getenv("OMP_NUM_THREADS");
    if (!env || !*env) omp_set_num_threads(available_cpus());
  }
#else
  (void)threads;
#endif
}

}  // namespace capsflow
