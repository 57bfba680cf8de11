#pragma once
// Helpers of the tests that run `capsflow run` in process and compare its files: quiet settings writing to a path,
// and bit-for-bit equality of one double dataset of two outputs (restart continuity).
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <string>

#include "host/base/h5_file.hpp"
#include "host/run/run_driver.hpp"

namespace capsflow::test {

inline RunSettings quiet_run(const std::filesystem::path& out) {
  RunSettings s;
  s.output = out.string();
  s.quiet = true;
  return s;
}

inline void expect_same_dataset(const H5File& a, const H5File& b, const std::string& path) {
  SCOPED_TRACE(path);
  const auto x = a.read<double>(path), y = b.read<double>(path);
  ASSERT_EQ(x.dims, y.dims);
  if (x.data.empty()) return;  // memcmp of an empty vector's null data() is undefined (UBSan)
  ASSERT_EQ(std::memcmp(x.data.data(), y.data.data(), x.data.size() * sizeof(double)), 0);
}

}  // namespace capsflow::test
