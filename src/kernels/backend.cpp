// The implementation of backend.hpp: execution backends of the flat-array kernels.
#include "kernels/backend.hpp"

#include <stdexcept>
#include <string>

#include "kernels/dispatch.hpp"

#ifdef CAPSFLOW_HAVE_OPENMP
#include <omp.h>
#endif

namespace capsflow {

bool device_backend_built() {
#ifdef CAPSFLOW_HAVE_OFFLOAD
  return true;
#else
  return false;
#endif
}

int device_count() {
#ifdef CAPSFLOW_HAVE_OFFLOAD
  return omp_get_num_devices();
#else
  return 0;
#endif
}

int host_thread_count() {
#ifdef CAPSFLOW_HAVE_OPENMP
  return omp_get_max_threads();
#else
  return 1;
#endif
}

void device_not_built(const char* kernel) {
  throw std::logic_error(std::string(kernel) +
                         ": called with backend 'device' in a build without CAPSFLOW_OFFLOAD (check the backend "
                         "with require_backend before any kernel runs)");
}

}  // namespace capsflow
