#pragma once
// One loop body per execution policy (architecture review R6; Cabana's parallel_for and parallel_reduce, Kokkos'
// execution policies as the models): a kernel entry writes its loop once, as a body over an index, and these run it
//
//   serial  - a plain loop in index order (the reference),
//   threads - an OpenMP parallel loop on the host (schedule(static), or schedule(dynamic, chunk) for uneven work),
//   device  - an OpenMP target region, `target teams distribute parallel for`, with the body inlined.
//
// The body is a lambda that captures by value ([=]) the flat arrays and scalars it reads: no Eigen, no virtual calls,
// nothing but plain loops over flat arrays, so it compiles for the device too. On the device the closure is mapped
// and its captured pointers translated to the device copies of their arrays (OpenMP 5.0's lambda rule: pointer
// captures are zero-length array sections; GCC 12 and clang implement it). The arrays must therefore be present on
// the device: the entry opens a data region around the call with its map clauses, as it wrote them on its combined
// construct before (CAPSFLOW_DEVICE_DATA; when a StepWorkspace has attached the arrays, the clauses find them present
// and copy nothing):
//
//     void fill3(Backend backend, std::size_t n, double value, double* a, double* b, double* c) {
//       require_built(backend, __func__);
//       CAPSFLOW_DEVICE_DATA(backend, map(from : a[0:n], b[0:n], c[0:n]))
//       for_each_index(backend, static_cast<long>(n), [=](long i) { a[i] = b[i] = c[i] = value; });
//     }
//
// Reductions (reduce_max, reduce_min, reduce_sum) return the combination of body(i) over i < n; they are meant for
// combinations that are exact in any order (max, min, integer sums), so every backend returns the serial value.
// A body that writes only its own index (or its own capsule's nodes) gives the same bits on every backend.
//
// Entries refuse the device in a build without it first (require_built, kernels/dispatch.hpp), so the helpers'
// own refusal below is a backstop that names the helper.
#include <type_traits>

#include "kernels/backend.hpp"
#include "kernels/dispatch.hpp"

#define CAPSFLOW_PRAGMA(...) _Pragma(#__VA_ARGS__)

// A data region around the next statement on the device backend only: CAPSFLOW_DEVICE_DATA(backend, map(...) ...).
// Expands to nothing in a build without offload.
#if defined(CAPSFLOW_HAVE_OFFLOAD)
#define CAPSFLOW_DEVICE_DATA(backend, ...) \
  CAPSFLOW_PRAGMA(omp target data if ((backend) == ::capsflow::Backend::Device) __VA_ARGS__)
#else
#define CAPSFLOW_DEVICE_DATA(backend, ...)
#endif

namespace capsflow {

// How the threads backend shares out the indices: static blocks (even work), or chunks of `chunk` handed out
// dynamically (uneven work: pairs, targets with different neighbour counts). Serial and device ignore it.
struct ThreadSchedule {
  int chunk = 0;  // 0: schedule(static); > 0: schedule(dynamic, chunk)
  static constexpr ThreadSchedule dynamic(int c) { return ThreadSchedule{c}; }
};

// body(i) for 0 <= i < n.
template <class Body>
inline void for_each_index(Backend backend, long n, const Body& body, ThreadSchedule schedule = {}) {
  switch (backend) {
    case Backend::Serial:
      for (long i = 0; i < n; ++i) body(i);
      return;
    case Backend::Threads:
      if (schedule.chunk > 0) {
#pragma omp parallel for schedule(dynamic, schedule.chunk)
        for (long i = 0; i < n; ++i) body(i);
      } else {
#pragma omp parallel for schedule(static)
        for (long i = 0; i < n; ++i) body(i);
      }
      return;
    case Backend::Device:
#if defined(CAPSFLOW_HAVE_OFFLOAD)
#pragma omp target teams distribute parallel for
      for (long i = 0; i < n; ++i) body(i);
#else
      device_not_built("for_each_index");
#endif
      return;
  }
}

// The largest of init and body(i), 0 <= i < n (a > b ? a : b, so NaNs from the body are passed over).
template <class T, class Body>
inline T reduce_max(Backend backend, long n, T init, const Body& body) {
  T r = init;
  switch (backend) {
    case Backend::Serial:
      for (long i = 0; i < n; ++i) {
        const T v = body(i);
        r = v > r ? v : r;
      }
      break;
    case Backend::Threads:
#pragma omp parallel for schedule(static) reduction(max : r)
      for (long i = 0; i < n; ++i) {
        const T v = body(i);
        r = v > r ? v : r;
      }
      break;
    case Backend::Device:
#if defined(CAPSFLOW_HAVE_OFFLOAD)
#pragma omp target teams distribute parallel for map(tofrom : r) reduction(max : r)
      for (long i = 0; i < n; ++i) {
        const T v = body(i);
        r = v > r ? v : r;
      }
#else
      device_not_built("reduce_max");
#endif
      break;
  }
  return r;
}

// The smallest of init and body(i), 0 <= i < n.
template <class T, class Body>
inline T reduce_min(Backend backend, long n, T init, const Body& body) {
  T r = init;
  switch (backend) {
    case Backend::Serial:
      for (long i = 0; i < n; ++i) {
        const T v = body(i);
        r = v < r ? v : r;
      }
      break;
    case Backend::Threads:
#pragma omp parallel for schedule(static) reduction(min : r)
      for (long i = 0; i < n; ++i) {
        const T v = body(i);
        r = v < r ? v : r;
      }
      break;
    case Backend::Device:
#if defined(CAPSFLOW_HAVE_OFFLOAD)
#pragma omp target teams distribute parallel for map(tofrom : r) reduction(min : r)
      for (long i = 0; i < n; ++i) {
        const T v = body(i);
        r = v < r ? v : r;
      }
#else
      device_not_built("reduce_min");
#endif
      break;
  }
  return r;
}

// init + the sum of body(i), 0 <= i < n: for integer counts (a floating-point sum would depend on the order).
template <class T, class Body>
inline T reduce_sum(Backend backend, long n, T init, const Body& body) {
  static_assert(!std::is_floating_point<T>::value, "reduce_sum is for exact (integer) sums");
  T r = init;
  switch (backend) {
    case Backend::Serial:
      for (long i = 0; i < n; ++i) r += body(i);
      break;
    case Backend::Threads:
#pragma omp parallel for schedule(static) reduction(+ : r)
      for (long i = 0; i < n; ++i) r += body(i);
      break;
    case Backend::Device:
#if defined(CAPSFLOW_HAVE_OFFLOAD)
#pragma omp target teams distribute parallel for map(tofrom : r) reduction(+ : r)
      for (long i = 0; i < n; ++i) r += body(i);
#else
      device_not_built("reduce_sum");
#endif
      break;
  }
  return r;
}

}  // namespace capsflow
