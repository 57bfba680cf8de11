#include "host/run_driver.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <optional>
#include <ostream>
#include <random>
#include <sstream>

#include "host/atomic_file.hpp"
#include "host/backend_select.hpp"
#include "host/checkpoint.hpp"
#include "host/errors.hpp"
#include "host/h5_file.hpp"
#include "host/run_layout.hpp"
#include "host/run_output.hpp"
#include "host/run_report.hpp"
#include "host/simulation.hpp"
#include "host/steady_state.hpp"
#include "host/stop_signal.hpp"
#include "host/stopwatch.hpp"
#include "host/thread_limits.hpp"

namespace capsflow {

namespace fs = std::filesystem;

namespace {

// Where the next record falls due after time t: the first multiple of `every` strictly above t (with a relative
// tolerance so that a step landing a rounding error short of a multiple does not skip it).
double next_multiple(double t, double every) { return (std::floor(t / every * (1.0 + 1e-12) + 1e-9) + 1.0) * every; }

bool due(double t, double when) { return t >= when - 1e-9 * std::max(1.0, std::abs(when)); }

std::string make_run_id() {
  std::random_device rd;
  std::ostringstream o;
  o << std::hex << rd() << rd() << "-" << std::chrono::system_clock::now().time_since_epoch().count();
  return o.str();
}

std::string strain_text(double t) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", t);
  return buf;
}

bool all_pinned(const Simulation& sim) {
  for (char p : sim.pinned())
    if (!p) return false;
  return !sim.pinned().empty();
}

// The values whose steadiness ends a pinned run: U_y and D of every capsule.
std::vector<double> steady_values(const Simulation& sim) {
  const CapsuleGeometry g = sim.geometry();
  const std::size_t np = g.volume.size();
  std::vector<double> v(2 * np);
  for (std::size_t k = 0; k < np; ++k) {
    v[2 * k] = sim.capsule_velocity()[3 * k + 1];
    v[2 * k + 1] = g.deformation[k].D;
  }
  return v;
}

}  // namespace

RunResult run_simulation(const Config& cfg_in, const RunSettings& settings, std::ostream& log) {
  const auto t_wall = std::chrono::steady_clock::now();
  const bool restart = !settings.restart.empty();
  Config cfg = cfg_in;
  std::optional<Checkpoint> ck;
  std::string run_id, output_file;
  OutputSchedule sched;
  if (restart) {
    // A truncated or damaged checkpoint is the user's to fix (another checkpoint, a rerun): exit 2, not "internal".
    try {
      ck.emplace(read_checkpoint(settings.restart));
    } catch (const InputError&) {
      throw;
    } catch (const std::exception& e) {
      throw InputError(settings.restart + ": cannot read the checkpoint (truncated or damaged?): " + e.what());
    }
    cfg = checkpoint_config(*ck, settings.restart);
    run_id = ck->run_id;
    output_file = ck->output_file;
    sched = ck->schedule;
  } else {
    run_id = make_run_id();
    output_file = cfg.output.file;
  }
  if (!settings.output.empty()) output_file = settings.output;
  if (settings.end) {
    if (!(*settings.end > 0.0) || !std::isfinite(*settings.end))
      throw InputError("--end: expected a finite number > 0 (strain units), got " + strain_text(*settings.end));
    if (restart && *settings.end < ck->state.time)
      throw InputError("--end: expected a strain at or above the checkpoint's (" + strain_text(ck->state.time) + "), got " +
                       strain_text(*settings.end));
    cfg.time.end = *settings.end;
  }
  std::string backend_from = cfg.source + ": [run] backend";
  if (settings.backend) {
    cfg.run.backend = parse_backend(*settings.backend, "--backend");
    backend_from = "--backend";
  }
  std::string threads_from = cfg.source + ": [run] threads";
  if (settings.threads) {
    cfg.run.threads = *settings.threads;
    threads_from = "--threads";
  }
  check_thread_count(cfg.run.threads, threads_from, cfg.run.backend == Backend::Threads ? log : null_stream());
  cfg.output.file = output_file;
  check_output_file_name(output_file, settings.output.empty() ? cfg.source + ": [output] file" : "--output");
  validate_run_config(cfg);
  try {
    require_backend(cfg.run.backend);
  } catch (const BackendUnavailable& e) {
    throw BackendUnavailable(backend_from + ": " + e.what());
  }
  if (cfg.run.backend == Backend::Threads) set_host_threads(cfg.run.threads);

  const RunPaths paths = run_paths(output_file);
  if (!restart) {
    // Fail in the first second, before any computing, if an output could not be written.
    for (const fs::path& p : {paths.h5, paths.xdmf, paths.checkpoint, paths.plot}) {
      ensure_can_create(p, settings.force);
      check_not_an_input(p, {{fs::path(cfg.source), "configuration"}});
    }
  } else {
    for (const fs::path& p : {paths.h5, paths.xdmf, paths.checkpoint, paths.plot}) check_output_kind(p);
    if (!fs::exists(paths.h5))
      throw InputError(paths.h5.string() + ": the output file of the checkpointed run does not exist (pass it with "
                       "--output)");
  }

  Simulation sim = restart ? Simulation(cfg, ck->state, settings.restart + ": ") : Simulation(cfg);
  // A pinned run that stops at steady state fits its slope over the last records; a restart re-reads them.
  std::optional<SteadyStateMonitor> steady;
  if (cfg.time.steady_stop && all_pinned(sim)) {
    std::vector<double> atol;
    for (std::size_t k = 0; k < sim.pinned().size(); ++k) {
      atol.push_back(cfg.time.steady_atol);    // U_y
      atol.push_back(cfg.time.steady_atol_D);  // D
    }
    steady.emplace(cfg.time.steady_window, cfg.time.steady_rtol, atol);
    if (restart) {
      RunFile old;
      try {
        old = read_run_file(paths.h5);
      } catch (const H5Error& e) {
        throw InputError(paths.h5.string() + ": cannot read the output to continue it (truncated, or locked by a run "
                         "still writing it?): " + e.what());
      }
      const std::size_t np = old.np, nrec = std::min<std::size_t>(old.records, static_cast<std::size_t>(sched.records));
      for (std::size_t r = 0; r < nrec && old.taylor_D.size() >= nrec * np; ++r) {
        std::vector<double> v(2 * np);
        for (std::size_t k = 0; k < np; ++k) {
          v[2 * k] = old.velocity[(r * np + k) * 3 + 1];
          v[2 * k + 1] = old.taylor_D[r * np + k];
        }
        steady->add(old.time[r], v);
      }
    }
  }
  std::optional<RunOutput> out_slot;
  try {
    out_slot.emplace(paths, sim, run_id, !restart, settings.force, sched);
  } catch (const H5Error& e) {
    // Continuing: the output is the user's file (truncated, older than the checkpoint, or open in a live run).
    if (!restart) throw;
    throw InputError(paths.h5.string() + ": cannot continue this output (truncated, or locked by a run still "
                     "writing it?): " + e.what());
  }
  RunOutput& out = *out_slot;
  // A new run that fails before its first checkpoint (disk full at the first record) removes the files it made, so
  // that the rerun is not refused for an existing output. Declared after `out`: it runs before out's destructor.
  struct RemoveUnlessKept {
    const RunPaths& paths;
    bool keep;
    ~RemoveUnlessKept() {
      if (keep) return;
      std::error_code ec;
      for (const fs::path& p : {paths.h5, paths.xdmf}) fs::remove(p, ec);
    }
  } made{paths, restart};

  const double end = *cfg.time.end;
  const bool talk = !settings.quiet;
  RunResult res;
  res.output = paths.h5.string();
  res.xdmf = paths.xdmf.string();
  res.checkpoint = paths.checkpoint.string();

  auto checkpoint = [&]() {
    Checkpoint c;
    c.format_version = out.format_version();
    c.run_id = run_id;
    c.output_file = fs::absolute(paths.h5).string();
    c.config_text = to_toml(cfg);
    c.schedule = sched;
    c.state = sim.snapshot();
    write_checkpoint(paths.checkpoint, c);
    made.keep = true;
  };

  if (talk) print_run_header(log, sim, paths, restart, end);

  RunTally tally;
  tally.t_start = sim.time();
  tally.events_start = sim.total_contact_events();
  ProgressLine progress(talk ? settings.progress_seconds : 0.0, sim.time(), end);
  const auto t_loop = std::chrono::steady_clock::now();

  for (;;) {
    sim.evaluate();
    const auto t0 = std::chrono::steady_clock::now();
    const double t = sim.time();
    bool steady_now = false;
    if (due(t, sched.next_record)) {
      const FlowDiagnostics fd = sim.flow_diagnostics();
      out.record(sim, fd);
      sim.mark_record();
      ++sched.records;
      sched.next_record = next_multiple(t, cfg.output.every);
      const double q = cfg.flow.type == FlowType::Shear ? fd.relative_viscosity : fd.flow_rate_ratio;
      if (std::isfinite(q)) {
        tally.flow_sum += q;
        ++tally.flow_records;
      }
      if (steady) {
        steady->add(t, steady_values(sim));
        steady_now = steady->steady();
      }
    }
    if (due(t, sched.next_frame)) {
      out.frame(sim);
      ++sched.frames;
      sched.next_frame = next_multiple(t, cfg.output.frames_every);
    }
    if (steady_now) {
      res.stop_message = "steady state reached at strain " + strain_text(t) + ": U_y and D of every capsule change "
                         " by less than max(steady_rtol |value|, steady_atol / steady_atol_d) per strain unit over the last " +
                         strain_text(cfg.time.steady_window) + " strain units";
      tally.io_seconds += seconds_since(t0);
      break;
    }
    if (due(t, end)) break;
    if (due(t, sched.next_checkpoint)) {
      sched.next_checkpoint = next_multiple(t, cfg.output.checkpoint_every);
      if (t > tally.t_start || !restart) checkpoint();
    }
    tally.io_seconds += seconds_since(t0);

    const int sig = stop_signal();
    if (sig != 0 || (settings.stop_after_steps >= 0 && tally.steps >= settings.stop_after_steps)) {
      checkpoint();
      res.exit_code = sig != 0 ? 128 + sig : 128 + SIGINT;
      res.stop_message = std::string("interrupted") + (sig == SIGTERM ? " (SIGTERM)" : sig ? " (SIGINT)" : "") +
                         " at strain " + strain_text(t) + "; continue with: capsflow run --restart " +
                         paths.checkpoint.string();
      break;
    }

    const StepInfo info = sim.advance();
    if (info.stop != StopReason::None) {
      checkpoint();
      res.exit_code = 3;
      res.stop_message = std::string("stopped early (") + stop_reason_name(info.stop) + "): " + info.message +
                         "; last good state in " + paths.checkpoint.string();
      break;
    }
    ++tally.steps;
    if (info.capped) ++tally.capped_steps;
    tally.timings += sim.last_timings();
    // Events go out with their step, so the count a checkpoint records is the count in the file.
    sched.events += static_cast<std::int64_t>(out.events(sim.take_events()));
    progress.step(log, sim, info, tally.steps);
  }
  tally.loop_seconds = seconds_since(t_loop);
  if (res.exit_code == 0) checkpoint();
  out.close();
  // The end phase answers SIGINT/SIGTERM too: the checkpoint and the output are complete; only the plot is left.
  if (const int sig = stop_signal(); sig != 0 && res.exit_code == 0) {
    res.exit_code = 128 + sig;
    res.stop_message = std::string("interrupted") + (sig == SIGTERM ? " (SIGTERM)" : " (SIGINT)") + " at the end (strain " +
                       strain_text(sim.time()) + "): the output and the checkpoint are complete, the trajectory plot "
                       "was not drawn";
  }
  if (stop_signal() == 0) write_trajectory_plot(read_run_file(paths.h5), cfg, paths.plot);

  res.steps = tally.steps;
  res.time = sim.time();
  res.wall_seconds = seconds_since(t_wall);
  if (talk) print_run_summary(log, sim, tally, paths, res.stop_message, res.wall_seconds);
  return res;
}

}  // namespace capsflow
