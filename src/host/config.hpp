#pragma once
// The run configuration: one TOML file, validated in one place (docs/usage.md lists every key).
//
// load_config() rejects unknown sections and keys, wrong types and out-of-range values with an InputError
// whose one-line message names the file, the key and what was expected.
#include <string>

#include "host/ggem_solver.hpp"
#include "kernels/backend.hpp"

namespace capsflow {

struct RunOptions {
  Backend backend = Backend::Serial;  // [run] backend = "serial" | "threads" | "device"
  int threads = 0;                    // [run] threads for 'threads' (0: OpenMP default)
};

struct Config {
  std::string source;  // file name, or "<embedded>" for the built-in demo
  SlitGeometry domain;  // [domain] H, Lx, Lz, viscosity
  GgemOptions ggem;     // [ggem] alpha, alpha_hm, nx, nz, ny, cutoff, chebyshev_rule
  RunOptions run;       // [run]
};

Config load_config(const std::string& path);
Config parse_config(const std::string& text, const std::string& source_name);

}  // namespace capsflow
