#include "kernels/backend.hpp"

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

}  // namespace capsflow
