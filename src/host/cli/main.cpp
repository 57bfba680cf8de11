// capsflow command line (docs/usage.md).
//
//   capsflow green CONFIG.toml --sources S.csv --targets T.csv --out U.csv   velocity of point forces (GGEM)
//   capsflow info                                                            what this build can run
//   capsflow demo [--out DIR]                                                the GGEM point-force demo
//   capsflow run [CONFIG.toml] [--output F] [--restart CK] [--backend B]     capsule suspension (README's demo
//                [--from RUN.h5 [--frame N]]                                 without CONFIG; --from: from a frame)
//   capsflow analyze RUN.h5|DIR ... --out DIR [--window T0:T1] [--bins N]     the study's analysis
//   capsflow figures ANALYSIS_DIR|RUN.h5... --out FIGDIR [--only F,..]     figures of the study, a run's diagnostics
//   capsflow render RUN.h5 --out DIR [--frame I] [--color F] [--movie]       3D pictures and a movie (ParaView)
//   capsflow flow RUN.h5 [--frame N] --plane z=V|--points F --out FLOW.h5     the fluid velocity of a frame
//   capsflow sweep SWEEP.toml --plan|--local|--slurm|--task I|--status      many runs of a study (docs/sweeps.md)
//
// Exit status: 0 success; 2 an error the user can fix (InputError: bad config, bad CSV, unavailable backend,
// existing output, command-line usage), printed as one line "capsflow: error: <message>"; 1 anything else.
#include <CLI/CLI.hpp>
#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fftw3.h>
#include <chrono>
#include <cmath>
#include <cctype>
#include <cstdlib>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <iostream>
#include <optional>
#include <string>
#include <system_error>
#include <vector>

#include "capsflow_version.hpp"
#include "host/base/stopwatch.hpp"
#include "host/cli/analyze_command.hpp"
#include "host/base/atomic_file.hpp"
#include "host/base/backend_select.hpp"
#include "host/base/build_info.hpp"
#include "host/physics/config.hpp"
#include "host/base/csv_io.hpp"
#include "host/cli/demo.hpp"
#include "host/cli/demo_summary.hpp"
#include "host/base/device_info.hpp"
#include "host/base/errors.hpp"
#include "host/cli/figures_command.hpp"
#include "host/cli/flow_command.hpp"
#include "host/cli/probe_command.hpp"
#include "host/cli/render_command.hpp"
#include "host/base/h5_file.hpp"
#include "host/base/machine_limits.hpp"
#include "host/run/run_driver.hpp"
#include "host/run/run_estimate.hpp"
#include "host/cli/sweep.hpp"
#include "host/base/thread_limits.hpp"
#include "host/solver/ggem_solver.hpp"
#include "kernels/backend.hpp"
#include "kernels/simd_path.hpp"

namespace {

using namespace capsflow;

constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;
constexpr int kExitInputError = 2;

// The study capsflow reproduces, named wherever a user first meets the program (--version, --help); CITATION.cff
// carries the same reference for citation tools.
constexpr const char* kPaperCitation =
    "Reproduces: A. Kumar and M. D. Graham, \"Segregation by membrane rigidity in flowing binary suspensions of "
    "elastic capsules\", Phys. Rev. E 84 (2011), arXiv:1109.6601.";
constexpr const char* kLicence = "Licence: BSD-3-Clause (LICENSE).";

std::string one_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

// A value echoed in a message can be anything the user typed (a 100 000-character --set): keep the line readable, with
// its start (the key, what was expected) and its end.
std::string abbreviate(std::string s) {
  constexpr std::size_t kMax = 1000;
  if (s.size() <= kMax) return s;
  const std::size_t n = s.size();
  return s.substr(0, 600) + " [... " + std::to_string(n - 800) + " characters left out ...] " + s.substr(n - 200);
}

void print_error(const std::string& message) {
  std::cerr << "capsflow: error: " << abbreviate(one_line(message)) << "\n";
}

// A process started with stdin, stdout or stderr closed would open its next file (the HDF5 output) as that
// descriptor and then write its messages into the file: give the closed ones /dev/null first.
void open_closed_standard_descriptors() {
  for (int fd = 0; fd <= 2; ++fd) {
    if (::fcntl(fd, F_GETFD) != -1 || errno != EBADF) continue;
    const int got = ::open("/dev/null", fd == 0 ? O_RDONLY : O_WRONLY);
    if (got >= 0 && got != fd) {  // not the lowest free descriptor (cannot happen in order 0, 1, 2): move it
      ::dup2(got, fd);
      ::close(got);
    }
  }
}

// What a command printed to stdout must have arrived: a full disk or a closed pipe behind `> out` is a failure.
int check_stdout(int status) {
  std::cout.flush();
  errno = 0;
  if (std::fflush(stdout) != 0 || std::ferror(stdout) || !std::cout) {
    const int err = errno;
    print_error(std::string("cannot write to standard output: ") + (err ? std::strerror(err) : "write error"));
    return status == kExitOk ? kExitFailure : status;
  }
  return status;
}

// Option checks that CLI11 runs on the text before converting it; the message follows the option name.
const CLI::Validator kNonEmpty(
    [](std::string& v) { return v.empty() ? std::string("expected a non-empty value, got an empty string") : ""; },
    "", "non-empty");

// A Slurm time limit: minutes, MM:SS, HH:MM:SS, D-HH, D-HH:MM or D-HH:MM:SS (sbatch --time; 0 is no limit): an
// optional "D-" and one to three groups of digits separated by ':'. (Hand-parsed: std::regex trips GCC 12's
// maybe-uninitialized warning under the sanitizers.)
bool is_slurm_time(const std::string& v) {
  std::size_t i = 0;
  const std::size_t dash = v.find('-');
  if (dash != std::string::npos) {
    if (dash == 0) return false;
    for (; i < dash; ++i)
      if (!std::isdigit(static_cast<unsigned char>(v[i]))) return false;
    i = dash + 1;
  }
  int groups = 0;
  while (true) {
    const std::size_t start = i;
    while (i < v.size() && std::isdigit(static_cast<unsigned char>(v[i]))) ++i;
    if (i == start) return false;
    ++groups;
    if (i == v.size()) return groups <= 3;
    if (v[i] != ':') return false;
    ++i;
  }
}
const CLI::Validator kSlurmTime(
    [](std::string& v) {
      return is_slurm_time(v) ? std::string()
                              : "expected a Slurm time limit (minutes, HH:MM:SS or D-HH:MM:SS), got '" + v + "'";
    },
    "", "Slurm time");

// A finite number >= lo (or > lo when `strict`): CLI11 alone converts "inf" and "nan".
CLI::Validator finite_number(double lo, bool strict) {
  return CLI::Validator(
      [lo, strict](std::string& v) -> std::string {
        char* end = nullptr;
        const double x = std::strtod(v.c_str(), &end);
        const bool ok = !v.empty() && end && *end == '\0' && std::isfinite(x) && (strict ? x > lo : x >= lo);
        if (ok) return "";
        char want[64];
        std::snprintf(want, sizeof want, "expected a finite number %s %g", strict ? ">" : ">=", lo);
        return std::string(want) + ", got '" + v + "'";
      },
      "", "finite");
}

// ---------------------------------------------------------------------------------------------------------
// capsflow green

struct GreenOptions {
  std::string config;
  std::string sources;
  std::string targets;
  std::string out;
  std::optional<std::string> backend;  // unset: [run] backend
  std::optional<int> threads;          // unset: [run] threads
  std::vector<std::string> sets;       // --set section.key=value
  bool force = false;
  bool quiet = false;
};

// --set, repeatable, for every command that reads a configuration.
void add_set_option(CLI::App* app, std::vector<std::string>& sets) {
  app->add_option("--set", sets,
                  "Override a configuration key, checked like the same key in the file (repeatable): "
                  "section.key=value, e.g. suspension.seed=3, species.2.ca=0.6, species.floppy.ca=0.5, "
                  "suspension.fractions=[0.8,0.2] (docs/usage.md)")
      ->type_name("KEY=VALUE")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
}

void add_green(CLI::App& app, GreenOptions& o) {
  CLI::App* green = app.add_subcommand(
      "green",
      "Velocity at target points induced by point forces in the periodic slit (GGEM Green's function): "
      "u(x_t) = sum_m G(x_t, x_m) f_m, no slip on the walls y = 0 and y = H, periodic in x and z.");
  green->add_option("CONFIG.toml", o.config, "Run configuration: [domain], [ggem], [run] (docs/usage.md)")
      ->required()
      ->type_name("CONFIG.toml");
  green->add_option("--sources", o.sources, "Point forces, CSV with header x,y,z,fx,fy,fz (0 <= y <= H)")
      ->required()
      ->check(kNonEmpty)
      ->type_name("S.csv");
  green->add_option("--targets", o.targets, "Target points, CSV with header x,y,z (0 <= y <= H)")
      ->required()
      ->check(kNonEmpty)
      ->type_name("T.csv");
  green->add_option("--out", o.out,
                    "Output velocities, CSV with header x,y,z,ux,uy,uz, one row per target in input order, "
                    "written atomically; an existing file is an error unless --force")
      ->required()
      ->check(kNonEmpty)
      ->type_name("U.csv");
  green->add_option_function<std::string>(
           "--backend", [&o](const std::string& b) { o.backend = b; },
           "Execution backend, overrides [run] backend: serial | threads | device")
      ->check(kNonEmpty)
      ->type_name("B");
  green->add_option_function<int>(
          "--threads", [&o](const int& n) { o.threads = n; },
          "OpenMP threads for the 'threads' backend, overrides [run] threads (0: OMP_NUM_THREADS, else the CPUs "
          "the process may use)")
      ->type_name("N");
  add_set_option(green, o.sets);
  green->add_flag("--force", o.force, "Replace the output file if it exists");
  green->add_flag("-q,--quiet", o.quiet, "Do not print the summary (grid, timings) on stderr");
  green->footer(
      "Example:\n  capsflow green examples/green.toml --sources examples/sources.csv "
      "--targets examples/targets.csv --out U.csv\n"
      "Exit status: 0 success, 2 input error (one line on stderr; no output written), 1 internal error.");
}


int run_green(const GreenOptions& o) {
  std::vector<ConfigOverride> overrides = parse_overrides(o.sets);
  for (const ConfigOverride& f : run_flag_overrides(std::nullopt, o.backend, o.threads)) overrides.push_back(f);
  const Config cfg = load_config(o.config, overrides);
  check_thread_count(cfg.run.threads, cfg.origin("[run] threads"),
                     cfg.run.backend == Backend::Threads ? std::cerr : null_stream());
  require_backend(cfg.run.backend, cfg.origin("[run] backend"));
  const RunSize size = run_size(cfg);
  check_memory_fits(cfg, size, estimate_memory(size), available_memory());

  // Cheap checks first: nothing expensive runs when the output could not be written anyway.
  check_output_path(o.out, o.force);
  check_not_an_input(o.out, {{o.config, "configuration"}, {o.sources, "sources CSV"}, {o.targets, "targets CSV"}});
  const PointForces src = read_point_forces_csv(o.sources);
  const TargetPoints tgt = read_targets_csv(o.targets);
  validate_in_slit(src, cfg.domain.H, o.sources);
  validate_in_slit(tgt, cfg.domain.H, o.targets);

  if (cfg.run.backend == Backend::Threads) set_host_threads(cfg.run.threads);

  const auto t_setup = std::chrono::steady_clock::now();
  GgemSolver solver(cfg.domain, cfg.ggem, cfg.run.backend);
  const double setup_s = seconds_since(t_setup);

  const std::size_t nt = tgt.size();
  std::vector<double> ux(nt), uy(nt), uz(nt);
  solver.apply(src.size(), src.x.data(), src.y.data(), src.z.data(), src.fx.data(), src.fy.data(), src.fz.data(),
               nt, tgt.x.data(), tgt.y.data(), tgt.z.data(), ux.data(), uy.data(), uz.data());

  write_velocities_csv(o.out, tgt, ux.data(), uy.data(), uz.data(), o.force);

  if (!o.quiet) {
    const GgemGrid& g = solver.grid();
    const GgemTimings& t = solver.last_timings();
    const int threads = cfg.run.backend == Backend::Serial ? 1 : host_thread_count();
    std::fprintf(stderr, "capsflow green: %zu point forces (%s) -> %zu targets (%s)\n", src.size(),
                 o.sources.c_str(), nt, o.targets.c_str());
    std::fprintf(stderr, "  domain   H = %g, Lx = %g, Lz = %g, viscosity = %g\n", cfg.domain.H, cfg.domain.Lx,
                 cfg.domain.Lz, cfg.domain.viscosity);
    std::fprintf(stderr, "  grid     nx = %d, nz = %d, Chebyshev N = %d (hx = %g, hz = %g), alpha = %g, cutoff = %g\n",
                 g.nx, g.nz, g.ny, g.hx, g.hz, g.alpha, g.cutoff);
    if (cfg.run.backend == Backend::Device)
      std::fprintf(stderr, "  backend  device\n");
    else
      std::fprintf(stderr, "  backend  %s (%d thread%s)\n", backend_name(cfg.run.backend), threads,
                   threads == 1 ? "" : "s");
    std::fprintf(stderr,
                 "  time [s] setup %.3g | apply: local %.3g, wall_bc %.3g, spread %.3g, global_solve %.3g, "
                 "interpolate %.3g, total %.3g\n",
                 setup_s, t.local, t.wall_bc, t.spread, t.global_solve, t.interpolate, t.total);
    std::fprintf(stderr, "  wrote    %s\n", o.out.c_str());
  }
  return kExitOk;
}

// `figures --only`: "figNN_name[, figNN_name ...]" (names of lower-case letters, digits and '_'), spaces allowed
// around the commas. (Hand-written: std::regex trips GCC 12's maybe-uninitialized warning under the sanitizers.)
bool is_figure_name_list(const std::string& s) {
  std::size_t i = 0;
  const auto skip_spaces = [&] {
    while (i < s.size() && s[i] == ' ') ++i;
  };
  const auto digit = [&](std::size_t k) { return k < s.size() && s[k] >= '0' && s[k] <= '9'; };
  const auto name_char = [](char c) { return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_'; };
  while (true) {
    skip_spaces();
    if (s.compare(i, 3, "fig") != 0 || !digit(i + 3) || !digit(i + 4) || i + 5 >= s.size() || s[i + 5] != '_')
      return false;
    i += 6;
    const std::size_t start = i;
    while (i < s.size() && name_char(s[i])) ++i;
    if (i == start) return false;
    skip_spaces();
    if (i == s.size()) return true;
    if (s[i] != ',') return false;
    ++i;
  }
}

// ---------------------------------------------------------------------------------------------------------
// capsflow info

int run_info() {
  std::printf("%s\n", build_description().c_str());
#ifdef __clang__
  const char* compiler = "clang";
#else
  const char* compiler = "gcc";
#endif
  std::printf("compiler   %s %s (C++ %ld)\n", compiler, __VERSION__, static_cast<long>(__cplusplus));
#ifdef NDEBUG
  std::printf("asserts    off\n");
#else
  std::printf("asserts    on\n");
#endif
#ifdef CAPSFLOW_HAVE_OPENMP
  std::printf("openmp     yes\n");
#else
  std::printf("openmp     no\n");
#endif
  std::printf("offload    %s\n", device_backend_built() ? "yes" : "no");
  std::printf("vector     %s (host loops; this CPU's best: %s; CAPSFLOW_SIMD=portable|avx2|avx512 caps it)\n",
              simd_path_name(host_simd_path()), simd_path_name(cpu_simd_path()));
  std::printf("fftw       %s (planes transformed in parallel by the 'threads' backend)\n", fftw_version);
  set_host_threads(0);  // what [run] threads = 0 gives: OMP_NUM_THREADS, else the CPUs the process may use
  std::printf("threads    %d (for the 'threads' backend; OMP_NUM_THREADS or [run] threads change it)\n",
              host_thread_count());
  std::printf("cpus       %d available to this process (affinity mask and cgroup CPU quota)\n", available_cpus());
  const MemoryLimit mem = available_memory();
  if (mem.bytes > 0)
    std::printf("memory     %.1f GiB available to this process (%s)\n", static_cast<double>(mem.bytes) / (1 << 30),
                mem.what.c_str());
  std::printf("default    backend '%s' ([run] backend when the configuration does not name one)\n",
              backend_name(default_backend()));
  for (const std::string& line : device_report()) std::printf("%s\n", line.c_str());
  std::printf("backends\n");
  for (Backend b : {Backend::Serial, Backend::Threads, Backend::Device}) {
    try {
      require_backend(b);
      std::printf("  %-8s available\n", backend_name(b));
    } catch (const BackendUnavailable& e) {
      std::printf("  %-8s unavailable: %s\n", backend_name(b), e.what());
    }
  }
  return kExitOk;
}

// ---------------------------------------------------------------------------------------------------------
// capsflow run

struct RunCliOptions {
  std::string config;  // empty: the embedded demo (or the checkpoint's configuration with --restart)
  RunSettings settings;
  std::vector<std::string> sets;  // --set section.key=value
  bool print_demo = false;
  bool dry_run = false;
};

CLI::App* add_run(CLI::App& app, RunCliOptions& o) {
  CLI::App* run = app.add_subcommand(
      "run",
      "Simulate a capsule suspension in the slit (boundary integrals + GGEM, AB2 time stepping) and write an HDF5 "
      "time series, frames with a ParaView (XDMF) index, and checkpoints. Without CONFIG: a small built-in demo.");
  run->add_option("config", o.config, "Run configuration (docs/usage.md); omit for the embedded demo")
      ->type_name("CONFIG.toml");
  run->add_option("--output", o.settings.output, "Output HDF5 file, overrides [output] file")
      ->check(kNonEmpty)
      ->type_name("FILE.h5");
  run->add_option("--restart", o.settings.restart,
                  "Continue the run saved in this checkpoint (FILE.checkpoint.h5); its configuration is used")
      ->check(kNonEmpty)
      ->type_name("CHECKPOINT");
  run->add_option("--from", o.settings.from,
                  "Start a new run from a frame of this run's output: positions and reference shapes from the frame, "
                  "physics from CONFIG (capsule count, mesh level and species must agree)")
      ->check(kNonEmpty)
      ->type_name("RUN.h5");
  run->add_option_function<long>(
         "--frame", [&o](const long& f) { o.settings.from_frame = f; },
         "With --from: the frame to start from (0 the first, -1 the last; default: the last)")
      ->type_name("N");
  run->add_option_function<std::string>(
         "--backend", [&o](const std::string& b) { o.settings.backend = b; },
         "Execution backend, overrides [run] backend: serial | threads | device")
      ->check(kNonEmpty)
      ->type_name("B");
  run->add_option_function<int>(
         "--threads", [&o](const int& n) { o.settings.threads = n; },
         "OpenMP threads for the 'threads' backend, overrides [run] threads (0: OMP_NUM_THREADS, else the CPUs "
         "the process may use)")
      ->type_name("N");
  run->add_option_function<double>(
         "--end", [&o](const double& e) { o.settings.end = e; },
         "Strain at which to stop, overrides [time] end (e.g. to extend a restarted run)")
      ->check(finite_number(0.0, true))
      ->type_name("T");
  run->add_option("--progress", o.settings.progress_seconds, "Seconds between progress lines (0: none)")
      ->check(finite_number(0.0, false))
      ->capture_default_str();
  add_set_option(run, o.sets);
  run->add_flag("--force", o.settings.force, "Replace existing output files");
  run->add_flag("--dry-run", o.dry_run,
                "Check everything, print the resolved configuration (TOML) with the grid, the memory needed and an "
                "estimate of the cost per strain unit, and exit without writing anything");
  run->add_flag("--print-demo-config", o.print_demo, "Print the embedded demo's configuration (TOML) and exit");
  run->add_flag("-q,--quiet", o.settings.quiet, "No progress lines and no summary");
  run->footer(
      "Examples:\n  capsflow run                                  the embedded demo (writes capsflow-run-demo/)\n"
      "  capsflow run examples/run_binary.toml\n"
      "  capsflow run --restart run_binary.checkpoint.h5 --end 200\n"
      "  capsflow run examples/run_binary.toml --from run_binary.h5 --frame -1 --output branch.h5\n"
      "  capsflow run examples/presets/set_a.toml --set suspension.seed=3 --dry-run\n"
      "SIGINT/SIGTERM/SIGUSR1 (Ctrl-C) writes a checkpoint and stops; a second one kills.\n"
      "Exit status: 0 reached the end, 2 input error, 3 stopped early (non-finite values, a capsule leaving the "
      "slit, dt below the floor; last good state checkpointed), 128+signal interrupted (checkpointed), 1 an I/O "
      "failure (a full disk).");
  return run;
}

int run_run(RunCliOptions& o) {
  if (o.print_demo) {
    std::cout << embedded_demo_config();
    return kExitOk;
  }
  // --end, --backend and --threads are overrides too (after the --set ones); a new run applies them here, a restart
  // to the checkpoint's configuration.
  std::vector<ConfigOverride> overrides = parse_overrides(o.sets);
  for (const ConfigOverride& f : run_flag_overrides(o.settings.end, o.settings.backend, o.settings.threads))
    overrides.push_back(f);
  o.settings.end.reset();
  o.settings.backend.reset();
  o.settings.threads.reset();
  if (o.settings.from_frame && o.settings.from.empty())
    throw InputError("--frame: needs --from RUN.h5 (the run whose frame to start from)");
  if (!o.settings.from.empty() && (o.config.empty() || !o.settings.restart.empty()))
    throw InputError("--from " + o.settings.from + ": needs CONFIG (the physics of the new run) and no --restart " +
                     "(a restart continues its own run)");
  Config cfg;
  bool embedded_demo = false;
  if (!o.settings.restart.empty()) {
    if (!o.config.empty())
      throw InputError("capsflow run: give either CONFIG or --restart CHECKPOINT, not both (a restart uses the "
                       "configuration stored in the checkpoint; --end, --backend, --threads and run-control --set "
                       "keys override it)");
    o.settings.overrides = overrides;
  } else if (o.config.empty()) {
    cfg = resolve_config(embedded_demo_config(), "<embedded demo>", overrides);
    if (o.dry_run) return dry_run(cfg, o.settings, std::cout);
    const std::string file = o.settings.output.empty() ? cfg.output.file : o.settings.output;
    const std::filesystem::path dir = std::filesystem::path(file).parent_path();
    if (!dir.empty()) std::filesystem::create_directories(dir);
    std::cerr << "capsflow run: no CONFIG given: running the embedded demo (capsflow run --help)\n";
    embedded_demo = true;
  } else {
    cfg = load_config(o.config, overrides);
  }
  if (o.dry_run) return dry_run(cfg, o.settings, std::cout);
  install_stop_signal_handlers();
  const RunResult r = run_simulation(cfg, o.settings, std::cerr);
  if (r.exit_code != 0 && o.settings.quiet) print_error(r.stop_message);
  // The demo ends by saying what it shows, measured from the file it wrote (stdout: tools/demo.sh keeps it).
  if (embedded_demo && r.exit_code == kExitOk && !o.settings.quiet)
    std::cout << demo_look_text(o.settings.output.empty() ? cfg.output.file : o.settings.output) << std::flush;
  return r.exit_code;
}

// ---------------------------------------------------------------------------------------------------------
// capsflow sweep

// This program, for the children of --local and the Slurm script: /proc/self/exe, else argv[0] as given.
std::string self_executable(const char* argv0) {
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec && !self.empty()) return self.string();
  return std::filesystem::absolute(argv0, ec).string();
}

CLI::App* add_sweep(CLI::App& app, SweepOptions& o) {
  CLI::App* sw = app.add_subcommand(
      "sweep", "Many runs of one study from a sweep file (a base preset, the points as overrides, an output "
               "root): plan them, run them here or on Slurm, resume them, report their state (docs/sweeps.md)");
  sw->add_option("SWEEP.toml", o.file, "Sweep file (docs/sweeps.md)")->required()->type_name("SWEEP.toml");
  CLI::Option_group* verbs = sw->add_option_group("verb", "What to do (one of)");
  verbs->add_flag("--plan", "The runs, their directories and state, estimated cost and disk, a suggested Slurm "
                            "time limit (the default)");
  verbs->add_flag("--local", "Run here, --jobs at a time; finished runs are skipped, interrupted ones continue "
                             "from their checkpoints, failed ones stay failed unless --retry-failed");
  verbs->add_flag("--slurm", "Write ROOT/slurm/NAME.sbatch, a job array with one task per run (--submit: sbatch it)");
  verbs->add_option("--task", o.task, "Run point I here (continue it from its checkpoint; nothing if done): what "
                                      "each --local child and Slurm array task runs")
      ->check(CLI::NonNegativeNumber)
      ->type_name("I");
  verbs->add_flag("--status", "Every run: pending, running, done, failed (with its last message), interrupted, "
                              "killed; strain reached and last update");
  verbs->require_option(0, 1);
  sw->add_option("--jobs", o.jobs, "--local: runs at a time")->check(CLI::PositiveNumber)->capture_default_str();
  sw->add_option("--threads", o.threads, "Threads per run (the 'threads' backend when > 1)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  sw->add_option_function<std::string>(
        "--backend", [&o](const std::string& b) { o.backend = b; },
        "Backend of every run, overrides [run] backend: serial | threads | device")
      ->check(CLI::IsMember({"serial", "threads", "device"}))
      ->type_name("B");
  sw->add_flag("--retry-failed", o.retry_failed, "Run failed points again (from their checkpoint when they have one)");
  sw->add_flag("--requeue", o.requeue, "--task under Slurm: after SIGUSR1 (the time-limit warning of the "
                                       "generated script) checkpoint and requeue the job (scontrol requeue)");
  sw->add_option("--partition", o.partition, "--slurm: #SBATCH --partition")->check(kNonEmpty)->type_name("P");
  sw->add_option("--time", o.time_limit, "--slurm: #SBATCH --time per task (default: the plan's suggestion)")
      ->check(kSlurmTime)
      ->type_name("HH:MM:SS");
  sw->add_option("--cpus-per-task", o.cpus_per_task, "--slurm: CPUs (threads) per run")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  sw->add_option("--gpus-per-task", o.gpus_per_task, "--slurm: GPUs per run (> 0: the device backend)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  sw->add_option("--account", o.account, "--slurm: #SBATCH --account")->check(kNonEmpty)->type_name("A");
  sw->add_option("--mem", o.mem, "--slurm: #SBATCH --mem per task")->check(kNonEmpty)->type_name("M");
  sw->add_option("--max-parallel", o.max_parallel, "--slurm: at most this many tasks at once (array %N; 0: no "
                                                   "limit)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  sw->add_option("--signal-seconds", o.signal_seconds,
                 "--slurm: SIGUSR1 this long before the time limit (0: from the estimated step time, >= 120)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  sw->add_option("--sbatch-extra", o.extra, "--slurm: one more #SBATCH line, e.g. '--qos=long'")->check(kNonEmpty)->type_name("OPT");
  sw->add_flag("--submit", o.submit, "--slurm: run sbatch on the script");
  sw->footer(
      "Examples:\n  capsflow sweep examples/sweeps/set_a.toml --plan\n"
      "  capsflow sweep examples/sweeps/set_a.toml --local --jobs 2 --threads 8\n"
      "  capsflow sweep examples/sweeps/set_a.toml --slurm --partition cpu --cpus-per-task 16 --submit\n"
      "  capsflow sweep examples/sweeps/set_a.toml --status\n" +
      std::string(kSweepExitStatusHelp));
  return sw;
}

void resolve_sweep_verb(const CLI::App& sw, SweepOptions& o) {
  if (sw.count("--local")) o.verb = SweepOptions::Verb::Local;
  else if (sw.count("--slurm")) o.verb = SweepOptions::Verb::Slurm;
  else if (sw.count("--task")) o.verb = SweepOptions::Verb::Task;
  else if (sw.count("--status")) o.verb = SweepOptions::Verb::Status;
  else o.verb = SweepOptions::Verb::Plan;
}

int capsflow_main(int argc, char** argv);

}  // namespace

int main(int argc, char** argv) {
  open_closed_standard_descriptors();
  return check_stdout(capsflow_main(argc, argv));
}

namespace {

int capsflow_main(int argc, char** argv) {
  CLI::App app{"capsflow " CAPSFLOW_VERSION_STRING
               ": boundary-integral Stokes flow of capsules in a slit (GGEM), periodic in x and z.",
               "capsflow"};
  app.set_version_flag("--version", build_description() + "\n" + kPaperCitation + "\n" + kLicence,
                       "Print the version, the sources' commit, the paper the study reproduces and the licence, and exit");
  app.require_subcommand(1);
  app.footer("Run 'capsflow <command> --help' for the options of a command. Documentation: docs/usage.md\n" +
             std::string(kPaperCitation) + "\nHow to cite capsflow: CITATION.cff. " + kLicence);

  GreenOptions green;
  add_green(app, green);
  CLI::App* info = app.add_subcommand("info", "Print the build: version, compiler, backends, threads, devices");
  std::string demo_dir = "capsflow-demo";
  bool demo_force = false;
  int demo_threads = 0;
  CLI::App* demo = app.add_subcommand(
      "demo", "Run the GGEM point-force demo (a few seconds): the velocity profile of a point force between the "
              "walls against free space (DIR/profile.csv), and the paper's set A box of point forces, timed");
  demo->add_option("--out", demo_dir, "Directory for the demo's files")->check(kNonEmpty)->capture_default_str();
  demo->add_option("--threads", demo_threads, "OpenMP threads (0: the OpenMP default)")->check(CLI::NonNegativeNumber);
  demo->add_flag("--force", demo_force, "Replace the demo's files if the directory is not empty");

  RunCliOptions run_opts;
  CLI::App* run = add_run(app, run_opts);

  AnalyzeOptions analyze_opts;
  std::string analyze_window;
  CLI::App* analyze = app.add_subcommand(
      "analyze", "The study's analysis (docs/analysis.md) of run outputs: d-bar, profiles, enrichment, velocity "
                 "statistics, f_AB, isolated migration, pair collisions -> DIR/analysis.h5, summary.json, CSV");
  analyze->add_option("RUN.h5|DIR", analyze_opts.inputs, "Run outputs (OUT.h5) or directories searched for them")
      ->required()
      ->type_name("RUN.h5|DIR");
  analyze->add_option("--out", analyze_opts.out, "Output directory")->required()->check(kNonEmpty)->type_name("DIR");
  analyze->add_option("--window", analyze_window,
                      "Averaging window in strain (default: the last 1000 strain units, or the second half of a "
                      "shorter run)")
      ->type_name("T0:T1");
  analyze->add_option("--bins", analyze_opts.bins, "Folded wall-normal bins over [0, H/2]")->capture_default_str();
  analyze->add_flag("--force", analyze_opts.force, "Replace an earlier analysis in DIR");
  analyze->add_flag("-q,--quiet", analyze_opts.quiet, "No report on the terminal");
  std::vector<std::string> fig_dirs;
  std::string fig_out;
  bool fig_force = false;
  CLI::App* figures = app.add_subcommand(
      "figures", "Draw the figures of the segregation study (PNG + SVG) from capsflow analyze output, and a run's "
                 "diagnostics from its OUT.h5 (needs python3 with matplotlib and h5py; docs/usage.md)");
  figures->add_option("ANALYSIS_DIR|RUN.h5", fig_dirs,
                      "Directories holding analysis.h5 (the study's figures) and run outputs OUT.h5 (heights, D, "
                      "volume, dt and what bound it, contacts)")
      ->required()
      ->type_name("ANALYSIS_DIR|RUN.h5");
  figures->add_option("--out", fig_out, "Directory for the figures (created)")
      ->required()
      ->check(kNonEmpty)
      ->type_name("FIGDIR");
  figures->add_flag("--force", fig_force, "Replace existing figure files");
  std::string fig_only;
  figures->add_option("--only", fig_only,
                      "Only these of the study's figures, comma-separated (e.g. fig02_snapshots; the demo's 8 "
                      "capsules fill only its snapshot); default: every figure that has data")
      ->check(kNonEmpty)
      ->type_name("NAMES");
  figures->footer("Exit status: 0 done (a figure without data is skipped with a note), 2 input error, 1 a figure "
                  "failed to draw.");

  RenderOptions render_opts;
  CLI::App* render = add_render(app, render_opts);

  FlowCommandOptions flow_opts;
  CLI::App* flow = add_flow(app, flow_opts);

  ProbeOptions probe_opts;
  CLI::App* probe = add_probe(app, probe_opts);

  SweepOptions sweep_opts;
  CLI::App* sweep = add_sweep(app, sweep_opts);
  sweep_opts.executable = self_executable(argc > 0 ? argv[0] : "capsflow");

  // CLI11 reports a mistyped command as "A subcommand is required": name it instead.
  if (argc > 1 && argv[1][0] != '-') {
    bool known = false;
    std::string names;
    for (const CLI::App* sub : app.get_subcommands({})) {
      known = known || sub->get_name() == argv[1];
      names += (names.empty() ? "" : ", ") + sub->get_name();
    }
    if (!known) {
      print_error(std::string("unknown command '") + argv[1] + "': expected one of " + names +
                  " (run 'capsflow --help')");
      return kExitInputError;
    }
  }
  // CLI11 answers an unknown option before the command with "A subcommand is required": name the option instead.
  if (argc > 1 && argv[1][0] == '-') {
    const std::string a = argv[1];
    if (a != "-h" && a != "--help" && a != "--version") {
      std::string names;
      for (const CLI::App* sub : app.get_subcommands({})) names += (names.empty() ? "" : ", ") + sub->get_name();
      print_error("unknown option '" + a + "' before the command: expected a command (" + names +
                  ") or --help or --version");
      return kExitInputError;
    }
  }

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    print_error(std::string(e.what()) + " (run 'capsflow --help')");
    return kExitInputError;
  }

  try {
    // Before the first parallel region: libgomp crashes or exits inside the runtime on a count it cannot create.
    check_thread_environment();
    // Before any kernel fixes the process's vector path (kernels/simd_path.hpp).
    if (const std::string simd = simd_environment_problem(); !simd.empty()) throw InputError(simd);
    if (app.got_subcommand("green")) return run_green(green);
    if (info->parsed()) return run_info();
    if (demo->parsed()) return run_demo(demo_dir, demo_force, demo_threads);
    if (run->parsed()) return run_run(run_opts);
    if (analyze->parsed()) {
      if (!analyze_window.empty()) parse_window(analyze_window, analyze_opts);
      return run_analyze(analyze_opts, std::cout);
    }
    if (figures->parsed()) {
      // Before the inputs are opened: a name that cannot be a figure's (figNN_name) is named here, one the script
      // does not draw by the script; given but empty would draw everything, which nobody who names figures asks.
      if (figures->count("--only") > 0 && !is_figure_name_list(fig_only))
        throw InputError("--only: expected the study's figure names, comma-separated (e.g. fig02_snapshots), got '" +
                         fig_only + "'");
      return run_figures(fig_dirs, fig_out, fig_force, fig_only);
    }
    if (render->parsed()) return run_render(render_opts, std::cerr);
    if (flow->parsed()) return run_flow(flow_opts, std::cerr);
    if (probe->parsed()) return run_probe(probe_opts, std::cout);
    if (sweep->parsed()) {
      resolve_sweep_verb(*sweep, sweep_opts);
      return run_sweep(sweep_opts, std::cout);
    }
  } catch (const InputError& e) {
    print_error(e.what());
    return kExitInputError;
  } catch (const H5Error& e) {
    print_error(e.what());  // an I/O failure (disk full, permissions): the system's reason, exit 1
    return kExitFailure;
  } catch (const std::system_error& e) {
    print_error(e.what());
    return kExitFailure;
  } catch (const std::exception& e) {
    print_error(std::string("internal: ") + e.what());
    return kExitFailure;
  }
  return kExitFailure;  // unreachable: require_subcommand(1)
}

}  // namespace
