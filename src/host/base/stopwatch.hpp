#pragma once
// Wall-clock seconds since a time point: the stage timings of the solvers and the command line.
#include <chrono>

namespace capsflow {

inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace capsflow
