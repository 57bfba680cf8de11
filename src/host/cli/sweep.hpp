#pragma once
// `capsflow sweep SWEEP.toml`: many runs of one study from one file (docs/sweeps.md).
//
// A sweep file names a base configuration (a preset), the points (each a list of `--set` overrides of it) and an
// output root:
//
//   base = "../presets/set_a.toml"      # relative to the sweep file
//   root = "set_a"                      # relative to the sweep file; one directory per point below it
//   [set]                               # overrides of every point (not part of the directory names)
//   time.end = 2500
//   [[product]]                         # every combination of the value lists (keys in alphabetical order,
//   suspension.fractions = [[1.0, 0.0], [0.5, 0.5]]   # the last varying fastest)
//   suspension.seed = [1, 2, 3]
//   [[point]]                           # one point (series that are not products); may name its own base
//   base = "../presets/pair.toml"
//   capsule.2.center = [5.0, 15.5, 15.0]
//
// Keys are the keys of `capsflow run --set` (docs/usage.md "Overrides"). Each point's directory is named from the
// keys and values of its own block ([[product]] or [[point]]): "fractions-0.5_0.5__seed-2" (the last part of each
// key unless two keys of the sweep share it; array elements joined by '_'; characters outside [A-Za-z0-9._+-]
// replaced by '.'), unique within the sweep. It holds:
//   config.toml           the resolved configuration of the point (written before its run starts)
//   output.h5, output.xdmf, output.checkpoint.h5   the run's files (docs/usage.md)
//   output.lock           present while the run lives (run_marker.hpp): pid, host, heartbeat, strain
//   run.log               the run's progress and summary (appended by every attempt)
//   result                how the last attempt ended (JSON): exit status, message, strain reached
// A directory whose config.toml differs from its point (run-control keys aside: [time] end, [run] backend and
// threads, [output] file) is refused, exit 2, before anything is written.
//
// Verbs: --plan, --local, --slurm, --task I, --status (sweep_command; `capsflow sweep --help`).
//
// Refused with exit 2 before any file is written (docs/sweeps.md "What is refused, and why"): more than
// kMaxSweepPoints points; a `name` outside [A-Za-z0-9._+-] (starting with a letter or digit; --slurm also checks the
// default, the file's stem); for --slurm, every value that goes into the script unless it is a token of its
// documented character set (--partition, --account, --mem, --time, --sbatch-extra on one line starting with '-',
// the root without whitespace, quotes, backslashes, '%' or control characters); for --task and every point --local
// runs, everything `capsflow run --dry-run` checks, and output files that are links or not regular files.
#include <cstddef>
#include <filesystem>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

#include "host/physics/config.hpp"

namespace capsflow {

// The most points one sweep file may hold (the sum over its blocks; a [[product]] counts the product of its list
// lengths). Checked before any point is made: a larger study is split into several sweep files.
inline constexpr std::size_t kMaxSweepPoints = 10000;

// Exit statuses of `capsflow sweep` (docs/sweeps.md). --local returns 0 only when every point is done; 3 when a point
// is failed (it needs --retry-failed or a fix); otherwise kSweepExitNotDone while a point is not done (running in
// another process or on another host, interrupted or killed there, or pending): wait, or rerun to continue it.
inline constexpr int kSweepExitNotDone = 4;
// The same, for `capsflow sweep --help`'s footer.
inline constexpr const char* kSweepExitStatusHelp =
    "Exit status: 0 done (--local: every point done), 1 an I/O failure, 2 input error (nothing written: a bad sweep file or option, a "
    "point directory holding another configuration, a point already running for --task), 3 a point failed, 4 "
    "--local: not every point done (one runs elsewhere, or was interrupted or killed there: wait or rerun), "
    "128+signal interrupted (the runs checkpointed: rerun to continue).";

struct SweepPoint {
  std::size_t index = 0;
  std::filesystem::path base;                       // the base configuration file
  std::string block;                                // "[[product]] 1", "[[point]] 3": where it was defined
  std::vector<std::pair<std::string, std::string>> params;  // the block's key -> value (TOML text), in key order
  std::vector<ConfigOverride> overrides;            // [set], then params
  std::string name;                                 // directory name below the root
};

struct Sweep {
  std::filesystem::path file;   // the sweep file
  std::filesystem::path root;   // output root (absolute or relative to the working directory, as the file gave it
                                // resolved against the sweep file's directory)
  std::string name;             // `name` key, else the sweep file's stem: the Slurm job name
  std::vector<SweepPoint> points;
};

// Reads and checks a sweep file (InputError naming the file and key: unknown keys, empty value lists, no points,
// repeated points). Does not read the base configurations.
Sweep load_sweep(const std::string& path);

// The resolved configuration of a point: its base with its overrides, checked like `capsflow run`.
Config point_config(const Sweep& sweep, const SweepPoint& p);

// How a point's last attempt ended: the `result` file of its directory, a JSON object
// {"exit_code": 0, "strain": 1000.0070529793252, "end": 1000, "finished": 1796464020.9249797, "message": "..."}
// (finished: epoch seconds). The reader also takes the `key = value` lines written before 2026-12-07; a file it
// cannot parse reads as a failed attempt (exit_code 1).
struct SweepResult {
  int exit_code = 0;
  std::string message;
  double strain = 0.0, end = 0.0, finished = 0.0;
};
void write_sweep_result(const std::filesystem::path& p, const SweepResult& r);
std::optional<SweepResult> read_sweep_result(const std::filesystem::path& p);

// What `--status` reports for a point directory.
// Extendable: the run reached an earlier [time] end than the sweep file's (the end was raised); it continues.
enum class PointState { Pending, Running, Done, Failed, Interrupted, Killed, Extendable };
const char* point_state_name(PointState s);

struct PointStatus {
  PointState state = PointState::Pending;
  std::string message;             // failed: the last message; running/killed: the marker's description
  std::optional<double> strain;    // strain reached (marker or result)
  double end = 0.0;                // the point's [time] end
  std::optional<double> updated;   // last update, epoch seconds (heartbeat or result)
  bool has_checkpoint = false;
};
PointStatus inspect_point(const std::filesystem::path& dir, double end);

// The files of a point's directory.
struct PointPaths {
  std::filesystem::path dir, config, output, checkpoint, lock, log, result;
};
PointPaths point_paths(const Sweep& sweep, const SweepPoint& p);

// What --plan prints per run (and --slurm sizes its time limit and signal lead from): the configuration's cost
// estimate (run_estimate.hpp) for `threads` threads, and the disk at [time] end.
struct RunEstimate {
  double steps_per_strain = 0.0;   // mean over the run: fresh placement for 2 strain units, developed after
  double seconds_per_step = 0.0;
  double seconds = 0.0;            // the whole run, to [time] end
  double disk_bytes = 0.0;         // output + checkpoint at the end
};
RunEstimate estimate_run(const Config& c, int threads);

struct SweepOptions {
  std::string file;
  enum class Verb { Plan, Local, Slurm, Task, Status } verb = Verb::Plan;
  int jobs = 1;                     // --local: runs at a time
  int threads = 1;                  // --local / --task: threads per run (threads backend when > 1)
  std::optional<std::string> backend;  // --backend for every run
  bool retry_failed = false;
  long task = -1;                   // --task I
  bool requeue = false;             // --task under Slurm: requeue the job after SIGUSR1 (time-limit warning)
  // --slurm
  std::string partition, time_limit, account, mem, extra;
  int cpus_per_task = 1, gpus_per_task = 0, max_parallel = 0;
  int signal_seconds = 0;           // 0: chosen from the estimate (>= 120)
  bool submit = false;
  std::string executable;           // this program (for --local children and the Slurm script)
};

// Runs the verb; returns the exit status. InputError for bad input (exit 2 in main).
int run_sweep(const SweepOptions& o, std::ostream& out);

}  // namespace capsflow
