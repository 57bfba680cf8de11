#pragma once
// `capsflow probe CONFIG [--out FILE]`: the stability probe of the explicit membrane step (host/physics/
// stability_probe.hpp) on a configuration's initial state: the largest step AB2 can take there, measured (Arnoldi on
// the finite-difference Jacobian of the node velocities), against the step the configuration's [time] cfl chooses
// (docs/usage.md, "capsflow probe"; docs/method.md section 4.1).
//
// It runs on the host (a device configuration is probed with the threads backend), takes no step and writes nothing
// but FILE (JSON, with --out; an existing FILE is refused unless --force).
//
// Usage (src/host/cli/main.cpp):
//   ProbeOptions po;
//   CLI::App* probe = add_probe(app, po);
//   if (probe->parsed()) return run_probe(po, std::cout);   // 0 done, 2 input error
#include <ostream>
#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace capsflow {

struct ProbeOptions {
  std::string config;             // CONFIG (TOML)
  std::vector<std::string> sets;  // --set KEY=VALUE
  std::string out;                // --out FILE (JSON); empty: none
  bool force = false;             // --force: replace FILE
  int iterations = 40;            // --iterations: Arnoldi steps (velocity evaluations after the first)
};

// The `probe` subcommand with its options and their checks.
CLI::App* add_probe(CLI::App& app, ProbeOptions& o);

// Probes the configuration's initial state and prints the measured limit against the chosen cfl to `out`.
// InputError for a bad configuration or output path (nothing written).
int run_probe(const ProbeOptions& o, std::ostream& out);

}  // namespace capsflow
