#pragma once
// Backend harness for tests: one test body, run for every backend; the serial path is the oracle.
#include <gtest/gtest.h>

#include <string>

#include "host/backend_select.hpp"

namespace capsflow::test {

// Skips the current test, visibly, when backend b cannot run here (device not built or absent).
#define CAPSFLOW_SKIP_IF_UNAVAILABLE(b)                                                              \
  do {                                                                                             \
    if (!::capsflow::backend_available(b))                                                         \
      GTEST_SKIP() << "backend '" << ::capsflow::backend_name(b) << "' is not available here"     \
                   << (::capsflow::device_backend_built() ? " (no device visible)"                 \
                                                          : " (built without CAPSFLOW_OFFLOAD)"); \
  } while (0)

inline std::string backend_param_name(const ::testing::TestParamInfo<Backend>& info) {
  return backend_name(info.param);
}

}  // namespace capsflow::test
