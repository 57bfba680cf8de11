#pragma once
// `capsflow run`: drives a Simulation to [time] end and writes its output (docs/usage.md, docs/output_format.md).
//
// Files, for an output file OUT.h5 (from [output] file or --output):
//   OUT.h5             /parameters, /mesh, /capsules, /series (every [output] every), /frames (every frames_every);
//                      flushed after every record, so a killed run leaves a readable file up to its last record.
//   OUT.xdmf           ParaView index of /frames (rewritten atomically after each frame).
//   OUT.checkpoint.h5  the complete state, replaced atomically every checkpoint_every, at the end, on SIGINT/SIGTERM
//                      and when the run stops early.
// An existing output is an error (exit 2) unless `force`. A restart (--restart CK) reads the resolved configuration
// from the checkpoint, truncates OUT.h5 to the records the checkpoint had seen and continues, bit for bit. A run
// started from another run's frame (--from RUN.h5, frame_start.hpp) is a new run whose capsules are the frame's.
//
// The pieces: the file layout (run_layout.hpp), the output writer (run_output.hpp), checkpoints (checkpoint.hpp),
// what the user sees (run_report.hpp), signals (stop_signal.hpp); this file is the loop that ties them together.
//
// Exit status (run_simulation's RunResult::exit_code): 0 reached the end (or a steady state, [time] steady_stop);
// 3 stopped early (non-finite values, a
// capsule leaving the slit, dt below [time] dt_floor) with a final checkpoint of the last good state; 128 + signal
// after SIGINT / SIGTERM (checkpoint written). Input errors throw InputError (exit 2 in main).
#include <cstdint>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

#include "host/physics/config.hpp"
#include "host/run/embedded_demo.hpp"
#include "host/run/stop_signal.hpp"

namespace capsflow {

struct RunSettings {
  std::string output;                   // overrides [output] file when non-empty
  std::string restart;                  // checkpoint to continue from (empty: a new run)
  std::string from;                     // a run's output whose frame a new run starts from (empty: the placement)
  std::optional<long> from_frame;       // that frame (0 the first, negative from the end; unset: the last)
  bool force = false;                   // replace existing output files
  // Overrides of the configuration (config.hpp), applied before it is checked: to the checkpoint's configuration
  // on a restart (run-control keys only: check_restart_overrides), to `cfg` otherwise.
  std::vector<ConfigOverride> overrides;
  std::optional<double> end;            // overrides [time] end (e.g. to extend a restarted run); alias of the
                                        // override time.end, applied after `overrides`
  std::optional<std::string> backend;   // overrides [run] backend (alias of run.backend)
  std::optional<int> threads;           // overrides [run] threads (alias of run.threads)
  double progress_seconds = 5.0;        // a progress line at most this often (<= 0: none)
  bool quiet = false;                   // no progress and no summary
  long stop_after_steps = -1;           // >= 0: behave as if interrupted after that many steps (tests, benchmarks)
};

struct RunResult {
  int exit_code = 0;
  std::string stop_message;             // why it stopped early (empty when it reached the end)
  std::string output, xdmf, checkpoint; // the files written
  std::int64_t steps = 0;               // steps taken in this process
  double time = 0.0;                    // strain reached
  double wall_seconds = 0.0;
};

// Runs (or continues) a simulation. cfg is ignored for a restart (the checkpoint's configuration is used; the
// overrides in `settings` still apply). Progress and the summary go to `log`.
RunResult run_simulation(const Config& cfg, const RunSettings& settings, std::ostream& log);

// `capsflow run --dry-run`: every input check of run_simulation (overrides, restart rules, backend, the memory the
// grid needs against what the process may use), then prints to `out` the resolved configuration (TOML, runnable as
// it is) followed by "# " lines: the grid, the capsules, the memory, an estimate of the cost per strain unit
// (run_estimate.hpp) and the output files. Writes nothing. Returns 0; input errors throw InputError.
int dry_run(const Config& cfg, const RunSettings& settings, std::ostream& out);

}  // namespace capsflow
