#pragma once
// Backend harness for tests (Cabana's "one body per backend"): a test body written once against `backend()` runs on
// serial, threads and device; the serial path is the oracle for the others.
//
//   class Thing : public test::OnEachBackend {};
//   TEST_P(Thing, HasTheProperty) { ... run(backend()) ... EXPECT_LE(err, oracle_tol(1e-12)); }
//   CAPSFLOW_ON_EACH_BACKEND(Thing);           // physics: serial, threads, device against exact answers
//   CAPSFLOW_ON_PARALLEL_BACKENDS(Thing);      // compare tests: threads and device against a serial run
//
// Test names end in the backend ("/serial", "/threads", "/device"), so `ctest -R '/device$'` selects the device tests.
// A backend that cannot run here is skipped with the reason. In an offload build without a GPU, ctest sets
// CAPSFLOW_TEST_DEVICE_HOST_FALLBACK=1 (tests/CMakeLists.txt), so the device tests run their target regions on the
// OpenMP runtime's host fallback: arithmetic and control flow are checked, data movement is not (docs/device.md).
#include <gtest/gtest.h>

#include <optional>
#include <ostream>
#include <string>

#include "host/base/backend_select.hpp"

#ifdef CAPSFLOW_HAVE_OPENMP
#include <omp.h>
#endif

namespace capsflow {
// Readable parameter values in gtest messages.
inline void PrintTo(Backend b, std::ostream* os) { *os << backend_name(b); }
}  // namespace capsflow

namespace capsflow::test {

// Skips the current test, visibly, when backend b cannot run here (device not built or absent).
#define CAPSFLOW_SKIP_IF_UNAVAILABLE(b)                                                                            \
  do {                                                                                                             \
    if (!::capsflow::backend_available(b))                                                                         \
      GTEST_SKIP() << "backend '" << ::capsflow::backend_name(b) << "' is not available here"                     \
                   << (::capsflow::device_backend_built()                                                          \
                           ? " (no device visible; ctest sets CAPSFLOW_TEST_DEVICE_HOST_FALLBACK=1 to run it on "  \
                             "the host fallback)"                                                                  \
                           : " (built without CAPSFLOW_OFFLOAD)");                                                 \
  } while (0)

inline std::string backend_param_name(const ::testing::TestParamInfo<Backend>& info) {
  return backend_name(info.param);
}

inline const auto kEveryBackend = ::testing::Values(Backend::Serial, Backend::Threads, Backend::Device);
inline const auto kParallelBackends = ::testing::Values(Backend::Threads, Backend::Device);

// Sets the host thread count for a test and restores it afterwards, so the threads backend really splits work.
class ThreadCountGuard {
 public:
  explicit ThreadCountGuard(int threads) {
#ifdef CAPSFLOW_HAVE_OPENMP
    saved_ = omp_get_max_threads();
    omp_set_num_threads(threads);
#else
    (void)threads;
#endif
  }
  ~ThreadCountGuard() {
#ifdef CAPSFLOW_HAVE_OPENMP
    omp_set_num_threads(saved_);
#endif
  }
  ThreadCountGuard(const ThreadCountGuard&) = delete;
  ThreadCountGuard& operator=(const ThreadCountGuard&) = delete;

 private:
  int saved_ = 1;
};

class OnEachBackend : public ::testing::TestWithParam<Backend> {
 protected:
  void SetUp() override {
    CAPSFLOW_SKIP_IF_UNAVAILABLE(GetParam());
    guard_.emplace(2);  // at least two threads for 'threads' and for the device's host fallback
  }
  Backend backend() const { return GetParam(); }
  // Tolerance against the serial oracle: 0 on the host backends (same sums in the same order), `device` on the
  // device (atomics and the device's own libm reorder or round differently).
  double oracle_tol(double device) const { return backend() == Backend::Device ? device : 0.0; }

 private:
  std::optional<ThreadCountGuard> guard_;
};

#define CAPSFLOW_ON_EACH_BACKEND(Suite) \
  INSTANTIATE_TEST_SUITE_P(Backends, Suite, ::capsflow::test::kEveryBackend, ::capsflow::test::backend_param_name)
#define CAPSFLOW_ON_PARALLEL_BACKENDS(Suite)                                   \
  INSTANTIATE_TEST_SUITE_P(Backends, Suite, ::capsflow::test::kParallelBackends, \
                           ::capsflow::test::backend_param_name)

}  // namespace capsflow::test
