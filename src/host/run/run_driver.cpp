// The implementation of run_driver.hpp: `capsflow run`'s driver (a Simulation, its output, restarts).
#include "host/run/run_driver.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <iostream>
#include <optional>
#include <ostream>
#include <random>
#include <iomanip>
#include <sstream>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "host/base/atomic_file.hpp"
#include "host/base/backend_select.hpp"
#include "host/base/device_info.hpp"
#include "host/run/checkpoint.hpp"
#include "host/run/frame_start.hpp"
#include "host/physics/config.hpp"
#include "host/base/errors.hpp"
#include "host/base/h5_file.hpp"
#include "host/base/machine_limits.hpp"
#include "host/run/run_estimate.hpp"
#include "host/run/run_layout.hpp"
#include "host/run/run_marker.hpp"
#include "host/run/run_output.hpp"
#include "host/run/run_report.hpp"
#include "host/physics/simulation.hpp"
#include "host/physics/step_watch.hpp"
#include "host/run/steady_state.hpp"
#include "host/run/stop_signal.hpp"
#include "host/base/stopwatch.hpp"
#include "host/base/thread_limits.hpp"

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
  // Fixed width (each draw as 8 hex digits): the id is stored in the files, and an id of varying length moved their
  // layout, and the number of writes a run makes, by chance (the fault-injection tests count them).
  o << std::hex << std::setfill('0') << std::setw(8) << (rd() & 0xffffffffu) << std::setw(8) << (rd() & 0xffffffffu)
    << "-" << std::chrono::system_clock::now().time_since_epoch().count();
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

std::string signal_label(int sig) { return sig == 0 ? "" : " (" + signal_name(sig) + ")"; }

// A new start finds the marker of an earlier process that is gone (killed, or failed with an error). What that
// process left is replaced when it cannot hold anything worth keeping: no checkpoint (it died before its first
// one), and an OUT.h5 that is absent, unreadable (killed before its first flush) or carries the marker's run id.
// An output of another run is left to ensure_can_create, which refuses it.
void remove_dead_start_leftovers(const RunPaths& paths, const RunMarker& m) {
  if (fs::exists(paths.checkpoint))
    throw InputError(paths.h5.string() + ": an earlier run was killed (" + describe_marker(m) +
                     ") after writing its checkpoint: continue it with capsflow run --restart " +
                     paths.checkpoint.string() + ", or pass --force to start over");
  bool ours = true;
  if (fs::exists(paths.h5)) {
    try {
      H5File f = H5File::open(paths.h5);
      if (f.has_attribute("/", layout::kAttrRunId))
        ours = f.attribute<std::string>("/", layout::kAttrRunId) == m.run_id;
    } catch (const std::exception&) {
      ours = true;  // not a readable HDF5 file: the torn start of the marker's process
    }
  }
  if (!ours) return;
  std::error_code ec;
  for (const fs::path& p : {paths.h5, paths.xdmf, paths.lock}) fs::remove(p, ec);
}

// x_top - x_bottom of a pair (unwrapped centroids; top: the larger y).
double pair_dx(const Simulation& sim) {
  const std::vector<double> c = sim.unwrapped_centroids(sim.geometry());
  const bool first_on_top = c[1] >= c[4];
  return first_on_top ? c[0] - c[3] : c[3] - c[0];
}

// Everything of a run that is decided from the input, with every input check, before any file is touched: shared
// by the run and the dry run.
struct PreparedRun {
  Config cfg;
  std::optional<Checkpoint> ck;
  std::optional<FrameStart> start;  // --from: the frame the new run starts from
  std::string output_file;
  RunSize size;
  MemoryEstimate memory;
};

// OUT.lock's marker, refused when a live run holds the output; a dead one (or none) is returned for the caller.
std::optional<RunMarker> refuse_live_run(const RunPaths& paths) {
  check_output_kind(paths.lock);  // a FIFO or a device as OUT.lock would block or swallow the marker
  std::optional<RunMarker> m = read_run_marker(paths.lock);
  if (m && marker_owner(*m) == MarkerOwner::Live)
    throw InputError(paths.h5.string() + ": in use by a live run, " + describe_marker(*m) + " (" +
                     paths.lock.string() + ")");
  return m;
}

// A continuation's inputs against each other, before anything is written (and in the dry run, which says "valid"
// only where the run would start): the checkpoint unchanged since its writer (its digests), then the output it
// extends (which must exist: check_checkpoint_output), unless a live run holds it.
void check_restart_inputs(const PreparedRun& p, const RunSettings& settings) {
  check_checkpoint_digests(*p.ck, settings.restart);
  const RunPaths paths = run_paths(p.output_file);
  check_output_kind(paths.h5);  // a FIFO would block the reads below
  refuse_live_run(paths);
  check_checkpoint_output(*p.ck, p.cfg, paths.h5, settings.restart);
}

PreparedRun prepare_run(const Config& cfg_in, const RunSettings& settings) {
  PreparedRun p;
  const bool restart = !settings.restart.empty();
  p.cfg = cfg_in;
  std::vector<ConfigOverride> overrides = settings.overrides;
  for (const ConfigOverride& o : run_flag_overrides(settings.end, settings.backend, settings.threads))
    overrides.push_back(o);
  if (restart) {
    check_restart_overrides(overrides);
    // A truncated or damaged checkpoint is the user's to fix (another checkpoint, a rerun): exit 2, not "internal".
    try {
      p.ck.emplace(read_checkpoint(settings.restart));
    } catch (const InputError&) {
      throw;
    } catch (const std::exception& e) {
      throw InputError(settings.restart + ": cannot read the checkpoint (truncated or damaged?): " + e.what());
    }
    p.cfg = checkpoint_config(*p.ck, settings.restart, overrides);
    check_checkpoint_state(*p.ck, p.cfg, settings.restart);
    // The output beside the checkpoint, not the absolute path stored in it: continuing a copy of a run directory
    // must extend the copy, never the original it was copied from.
    p.output_file = (fs::path(settings.restart).parent_path() / fs::path(p.ck->output_file).filename()).string();
    for (const ConfigOverride& o : overrides)
      if (o.key == "time.end" && *p.cfg.time.end < p.ck->state.time)
        throw InputError(o.origin + ": expected a strain at or above the checkpoint's (" +
                         strain_text(p.ck->state.time) + "), got " + strain_text(*p.cfg.time.end));
  } else {
    // The resolved text reads back as the same Config (to_toml), so the overrides are checked like file keys.
    if (!overrides.empty()) p.cfg = resolve_config(to_toml(cfg_in), cfg_in.source, overrides);
    p.output_file = p.cfg.output.file;
  }
  if (!settings.output.empty()) p.output_file = settings.output;
  if (restart) check_restart_inputs(p, settings);
  Config& cfg = p.cfg;
  cfg.output.file = p.output_file;
  check_output_file_name(p.output_file, settings.output.empty() ? cfg.origin("[output] file") : "--output");
  validate_run_config(cfg);
  check_thread_count(cfg.run.threads, cfg.origin("[run] threads"),
                     cfg.run.backend == Backend::Threads ? std::cerr : null_stream());
  require_backend(cfg.run.backend, cfg.origin("[run] backend"));
  if (!settings.from.empty()) {
    p.start.emplace(read_frame_start(settings.from, settings.from_frame));
    check_frame_fits(*p.start, cfg);
  }
  if (cfg.run.backend == Backend::Threads) set_host_threads(cfg.run.threads);
  p.size = run_size(cfg);
  p.memory = estimate_memory(p.size);
  check_memory_fits(cfg, p.size, p.memory, available_memory());
  return p;
}

// The simulation of a prepared run: a new one, or the checkpoint's state continued.
Simulation make_simulation(const PreparedRun& p, const RunSettings& settings) {
  if (p.start) return Simulation(p.cfg, p.start->state, p.start->file + ": ");
  return p.ck ? Simulation(p.cfg, p.ck->state, settings.restart + ": ") : Simulation(p.cfg);
}

// The next step's size is known once the simulation exists: values that pass each key's range but give no step
// (cfl 1e300, Ca 1e-300, dt_floor above the step, a damaged checkpoint) are refused before any file is written.
void check_first_step(Simulation& sim, const PreparedRun& p, const RunSettings& settings) {
  const std::string why = sim.next_step_problem();
  if (why.empty()) return;
  // A continuation cannot change the keys the message names (the checkpoint fixes the physics), and the checkpoint
  // of a run that went on takes its next step (the run plans it before it checkpoints): unless the run stopped early
  // on this very step, the state is what is wrong (positions swapped with u_previous in a checkpoint without digests
  // were blamed on [time] c_gap).
  if (p.ck)
    throw InputError(settings.restart + ": the checkpoint's state gives no next step (" + why +
                     "); --restart cannot change the keys named: if its run stopped early on this step (exit 3), it "
                     "cannot go on with the same physics; otherwise the checkpoint is damaged or edited");
  throw InputError(p.cfg.source + ": " + why);
}

// Every output path checked before anything is written: none is an input (--force never replaces one: the
// configuration of a new run, the checkpoint of a restart, which only the new checkpoint may replace, atomically),
// none belongs to a live run; a new run clears what a dead start left and fails in the first second, before any
// computing, if an output could not be written. Then the temporaries of a process
// that was killed while replacing one of these files go (no live run owns them now).
void claim_outputs(const RunPaths& paths, const Config& cfg, const RunSettings& settings) {
  const bool restart = !settings.restart.empty();
  for (const fs::path& p : {paths.h5, paths.xdmf, paths.lock})
    check_not_an_input(p, {{restart ? fs::path(settings.restart) : fs::path(cfg.source),
                            restart ? "checkpoint" : "configuration"}});
  if (!restart) check_not_an_input(paths.checkpoint, {{fs::path(cfg.source), "configuration"}});
  if (!settings.from.empty())
    for (const fs::path& p : {paths.h5, paths.xdmf, paths.checkpoint, paths.lock})
      check_not_an_input(p, {{fs::path(settings.from), "run whose frame starts this one (--from)"},
                             {run_paths(settings.from).checkpoint, "checkpoint beside --from's run"}});
  const std::optional<RunMarker> old_marker = refuse_live_run(paths);
  if (!restart) {
    if (old_marker && !settings.force) remove_dead_start_leftovers(paths, *old_marker);
    for (const fs::path& p : {paths.h5, paths.xdmf, paths.checkpoint}) ensure_can_create(p, settings.force);
  } else {
    // (That the output exists, is the run's own and agrees with the checkpoint: prepare_run's check_restart_inputs.)
    for (const fs::path& p : {paths.h5, paths.xdmf, paths.checkpoint}) check_output_kind(p);
  }
  for (const fs::path& p : {paths.h5, paths.xdmf, paths.checkpoint, paths.lock}) remove_stale_temporaries(p);
}

// A failed device allocation aborts the process inside the OpenMP runtime: the largest step's need is checked first.
void check_device_memory(const Simulation& sim) {
  const GgemGrid& g = sim.grid();
  const std::size_t grid_points = static_cast<std::size_t>(g.ny + 1) * g.nx * g.nz;
  require_device_memory(device_bytes_per_step(grid_points, sim.state().x.size()),
                        "the run (" + std::to_string(sim.state().x.size()) + " nodes, grid " + std::to_string(g.nx) +
                            " x " + std::to_string(g.nz) + " x " + std::to_string(g.ny + 1) + ")");
}

// Whether `path` is a readable checkpoint of the run `run_id`.
bool checkpoint_of(const fs::path& path, const std::string& run_id) {
  try {
    return read_checkpoint(path).run_id == run_id;
  } catch (const std::exception&) {
    return false;
  }
}

// `make()` while the marker is on disk but nothing else is: when it fails, the marker goes (nothing written yet,
// nothing to recognise later).
template <class Make>
auto before_first_write(RunMarkerFile& marker, Make&& make) -> decltype(make()) {
  try {
    return make();
  } catch (...) {
    marker.release();
    throw;
  }
}

// The records of a continued run's output, fed again to the steady-state rule (the records its checkpoint covers).
void replay_steady_records(SteadyStateMonitor& steady, const fs::path& h5, std::int64_t records) {
  RunFile old;
  try {
    old = read_run_file(h5);
  } catch (const H5Error& e) {
    throw InputError(h5.string() + ": cannot read the output to continue it (truncated, or locked by a run "
                     "still writing it?): " + e.what());
  }
  const std::size_t np = old.np, nrec = std::min<std::size_t>(old.records, static_cast<std::size_t>(records));
  for (std::size_t r = 0; r < nrec && old.taylor_D.size() >= nrec * np; ++r) {
    std::vector<double> v(2 * np);
    for (std::size_t k = 0; k < np; ++k) {
      v[2 * k] = old.velocity[(r * np + k) * 3 + 1];
      v[2 * k + 1] = old.taylor_D[r * np + k];
    }
    steady.add(old.time[r], v);
  }
}

// A pinned run that stops at steady state fits its slope over the last records; a restart re-reads them. None for
// other runs.
std::optional<SteadyStateMonitor> steady_monitor(const Config& cfg, const Simulation& sim, bool restart,
                                                 const RunPaths& paths, const OutputSchedule& sched) {
  std::optional<SteadyStateMonitor> steady;
  if (!(cfg.time.steady_stop && all_pinned(sim))) return steady;
  std::vector<double> atol;
  for (std::size_t k = 0; k < sim.pinned().size(); ++k) {
    atol.push_back(cfg.time.steady_atol);    // U_y
    atol.push_back(cfg.time.steady_atol_D);  // D
  }
  steady.emplace(cfg.time.steady_window, cfg.time.steady_rtol, atol);
  if (restart) replay_steady_records(*steady, paths.h5, sched.records);
  return steady;
}

// The output writer: a new file, or the checkpoint's output continued.
void open_output(std::optional<RunOutput>& slot, const RunPaths& paths, const Simulation& sim,
                 const std::string& run_id, bool restart, bool force, const OutputSchedule& sched) {
  try {
    slot.emplace(paths, sim, run_id, !restart, force, sched);
  } catch (const H5Error& e) {
    // Continuing: the output is the user's file (truncated, older than the checkpoint, or open in a live run).
    if (!restart) throw;
    throw InputError(paths.h5.string() + ": cannot continue this output (truncated, or locked by a run still "
                     "writing it?): " + e.what());
  }
}

// What the outputs due at the evaluated state did: whether a record was written, and whether it found U_y and D
// steady (the steady-state rule).
struct DueOutputs {
  bool recorded = false;
  bool steady = false;
};

// The time-series record and the mesh frame that fall due at the evaluated state (strain t), with the schedule
// moved on, the record's flow diagnostic tallied and the steady-state rule fed.
DueOutputs write_due_outputs(const Config& cfg, Simulation& sim, RunOutput& out, OutputSchedule& sched,
                             std::optional<SteadyStateMonitor>& steady, RunTally& tally) {
  const double t = sim.time();
  DueOutputs done;
  if (due(t, sched.next_record)) {
    done.recorded = true;
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
      done.steady = steady->steady();
    }
  }
  if (due(t, sched.next_frame)) {
    out.frame(sim);
    ++sched.frames;
    sched.next_frame = next_multiple(t, cfg.output.frames_every);
  }
  return done;
}

// The stop rules of [time], checked at the evaluated state (strain t) after its outputs: the pair's separation
// (stop_pair_dx, at a record), then the steady state (steady_stop). The message that ends the run (exit 0), or
// empty to go on.
std::string stop_rule_message(const Config& cfg, const Simulation& sim, const DueOutputs& done, double t) {
  if (done.recorded && cfg.time.stop_pair_dx) {
    const double dx = pair_dx(sim);
    if (dx >= *cfg.time.stop_pair_dx)
      return "pair separation reached at strain " + strain_text(t) + ": x_top - x_bottom = " + strain_text(dx) +
             " >= stop_pair_dx = " + strain_text(*cfg.time.stop_pair_dx);
  }
  if (done.steady)
    return "steady state reached at strain " + strain_text(t) + ": U_y and D of every capsule change "
           " by less than max(steady_rtol |value|, steady_atol / steady_atol_d) per strain unit over the last " +
           strain_text(cfg.time.steady_window) + " strain units";
  return "";
}

// A stop asked from outside: a signal (`sig`, 0 for none), or --stop-after-steps reached (as if SIGINT).
bool interrupted(const RunSettings& settings, std::int64_t steps, int sig) {
  return sig != 0 || (settings.stop_after_steps >= 0 && steps >= settings.stop_after_steps);
}

// One step taken, in this process's figures: the step, its interface solve (counted as Simulation counts it per
// record), what set its size, its timings and its contact events' displacements.
void tally_step(RunTally& tally, const Simulation& sim, const StepInfo& info,
                const std::vector<ContactEventRecord>& events) {
  ++tally.steps;
  if (sim.solves_interface_velocity()) tally.gmres.add(sim.last_gmres());
  if (info.capped) ++tally.capped_steps;
  ++tally.limits[static_cast<std::size_t>(info.limit)];
  tally.timings += sim.last_timings();
  for (const ContactEventRecord& e : events) tally.contact_dy += std::abs(e.dy_p) + std::abs(e.dy_q);
}

// A finished run's series, events and frame times are compressed now that they no longer grow (while the run
// lives they stay plain: compress_finished_output says why). Returns the summary's line (empty: none). A failure (a
// full disk has no room for the copy) leaves the plain output as it was, complete and continuable, and sets `error`
// to the one line the run then ends with (exit 1): a run that did not finish its work must not report success, or a
// script would go on with an output that is not what the configuration asked for (issue 55).
std::string compress_at_end(const RunPaths& paths, const Config& cfg, const fs::path& checkpoint, std::string& error) {
  std::string note;
  const auto t_compress = std::chrono::steady_clock::now();
  try {
    const std::uintmax_t before = fs::file_size(paths.h5);
    if (compress_finished_output(paths.h5, cfg.output.compression)) {
      char line[200];
      std::snprintf(line, sizeof line, "  compressed the series at the end (deflate %d): %.4g -> %.4g MB in %.2g s\n",
                    cfg.output.compression, static_cast<double>(before) / 1e6,
                    static_cast<double>(fs::file_size(paths.h5)) / 1e6, seconds_since(t_compress));
      note = line;
    }
  } catch (const std::exception& e) {
    // (Plain series, unless only the directory's sync after the compressed file's rename failed.)
    error = paths.h5.string() + ": cannot compress the series at the end of the run (" + e.what() +
            "); the output is complete, and `capsflow run --restart " + checkpoint.string() +
            "` compresses it once there is room";
  }
  return note;
}

}  // namespace

RunResult run_simulation(const Config& cfg_in, const RunSettings& settings, std::ostream& log) {
  const auto t_wall = std::chrono::steady_clock::now();
  const bool restart = !settings.restart.empty();
  // ---- inputs: every check that needs no file written, then the outputs claimed
  PreparedRun prepared = prepare_run(cfg_in, settings);
  const Config& cfg = prepared.cfg;
  const std::string run_id = restart ? prepared.ck->run_id : make_run_id();
  OutputSchedule sched;
  if (restart) sched = prepared.ck->schedule;
  const RunPaths paths = run_paths(prepared.output_file);
  claim_outputs(paths, cfg, settings);

  // ---- the simulation, under the marker, which goes to disk before the output it guards (see run_marker.hpp)
  RunMarkerFile marker(paths.lock, run_id, restart ? prepared.ck->state.time : 0.0, *cfg.time.end);
  Simulation sim = before_first_write(marker, [&] { return make_simulation(prepared, settings); });
  if (cfg.run.backend == Backend::Device) before_first_write(marker, [&] { check_device_memory(sim); });
  check_first_step(sim, prepared, settings);
  std::optional<SteadyStateMonitor> steady = steady_monitor(cfg, sim, restart, paths, sched);

  // ---- the output
  std::optional<RunOutput> out_slot;
  open_output(out_slot, paths, sim, run_id, restart, settings.force, sched);
  RunOutput& out = *out_slot;
  if (prepared.start) out.set_start(prepared.start->file, prepared.start->frame, prepared.start->strain);
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
    try {
      write_checkpoint(paths.checkpoint, c);
    } catch (...) {
      // The write can fail after its rename (the directory's sync): the checkpoint is then on disk, and the output it
      // continues must stay.
      made.keep = made.keep || checkpoint_of(paths.checkpoint, run_id);
      throw;
    }
    made.keep = true;
  };

  if (talk) print_run_header(log, sim, paths, restart, end);
  if (talk && prepared.start)
    log << "  capsules from " << prepared.start->file << " frame " << prepared.start->frame << " (strain "
        << strain_text(prepared.start->strain) << "), physics from " << cfg.source << "\n";
  if (out.repaired())
    log << "capsflow run: " << paths.h5.string() << " could not be changed in place (an earlier write failed, e.g. "
        << "on a full disk): rebuilt from the " << sched.records << " records and " << sched.frames
        << " frames its checkpoint covers\n";

  // ---- the step loop: evaluate, outputs due, stop rules, checkpoint due, plan, signals, advance
  RunTally tally;
  bool stopped_from_outside = false;  // a signal or --stop-after-steps ended the loop (after its checkpoint)
  tally.t_start = sim.time();
  tally.events_start = sim.total_contact_events();
  ProgressLine progress(talk ? settings.progress_seconds : 0.0, sim.time(), end);
  const auto t_loop = std::chrono::steady_clock::now();
  // A step far below what the configuration implies is said once, quiet or not (issue 37: a tiny c_gap made a run
  // of 5e5 steps per strain unit that was killed after 300 s without a word).
  StepWatch step_watch;

  const auto fail = [&](const StepInfo& info) {
    checkpoint();
    res.exit_code = 3;
    res.stop_message = std::string("stopped early (") + stop_reason_name(info.stop) + "): " + info.message +
                       "; last good state in " + paths.checkpoint.string();
  };
  for (;;) {
    sim.evaluate();
    // An interface-velocity solve that did not converge stops the run before its answer reaches a record or a frame:
    // the checkpoint holds this state with the first guess that solve started from, so a continuation with a larger
    // [gmres] max_iterations solves it again and writes the record the uninterrupted run writes, bit for bit.
    if (sim.solves_interface_velocity() && !sim.last_gmres().converged) {
      fail(sim.plan_step());  // gmres-not-converged (or not-finite), with its message; the state unchanged
      break;
    }
    const auto t0 = std::chrono::steady_clock::now();
    const double t = sim.time();
    const DueOutputs done = write_due_outputs(cfg, sim, out, sched, steady, tally);
    if (std::string stop = stop_rule_message(cfg, sim, done, t); !stop.empty()) {
      res.stop_message = std::move(stop);
      tally.io_seconds += seconds_since(t0);
      break;
    }
    if (due(t, end)) break;
    if (due(t, sched.next_checkpoint)) {
      sched.next_checkpoint = next_multiple(t, cfg.output.checkpoint_every);
      if (t > tally.t_start || !restart) checkpoint();
    }
    tally.io_seconds += seconds_since(t0);

    // The next step is planned before a stop signal is honoured: a run whose next step fails (dt below its floor)
    // has failed, even when a signal came first. An interrupted run's checkpoint can thus always continue, and a
    // sweep resumes its interrupted points rather than refusing the one whose continuation would fail at once.
    StepInfo info = sim.plan_step();
    if (info.stop != StopReason::None) {
      fail(info);
      break;
    }
    const int sig = stop_signal();
    if (interrupted(settings, tally.steps, sig)) {
      checkpoint();
      stopped_from_outside = true;
      res.exit_code = sig != 0 ? 128 + sig : 128 + SIGINT;
      res.stop_message = std::string("interrupted") + signal_label(sig) +
                         " at strain " + strain_text(t) + "; continue with: capsflow run --restart " +
                         paths.checkpoint.string();
      break;
    }
    info = sim.advance(std::move(info));
    if (info.stop != StopReason::None) {
      fail(info);
      break;
    }
    // Events go out with their step, so the count a checkpoint records is the count in the file.
    const std::vector<ContactEventRecord> ev = sim.take_events();
    tally_step(tally, sim, info, ev);
    sched.events += static_cast<std::int64_t>(out.events(ev));
    progress.step(log, sim, info, tally.steps);
    const std::string slow = step_watch.observe(cfg, info, sim.time(), sim.near_contact_range());
    if (!slow.empty()) log << "capsflow run: warning: " << slow << "\n";
    marker.beat(sim.time());
  }
  tally.loop_seconds = seconds_since(t_loop);

  // ---- the end: the last checkpoint, the output closed and compressed, the marker released
  // A restart with nothing to do (its end already reached) leaves the checkpoint as it was, and compresses the output
  // when a failed compression left it plain (a no-op on a compressed one).
  const bool finished = res.exit_code == 0 && !(restart && tally.steps == 0);
  if (finished) checkpoint();
  out.close();
  // A run stopped by a signal (Ctrl-C, a batch system's time limit) or --stop-after-steps is not live either: its
  // series are compressed like a finished run's (the continuation makes them plain again before it appends). A kill
  // during the compression leaves the plain output, complete (compress_finished_output replaces it atomically).
  std::string compress_error;
  const std::string compressed_note = res.exit_code == 0 || stopped_from_outside
                                          ? compress_at_end(paths, cfg, paths.checkpoint, compress_error)
                                          : std::string();
  // Stopped from outside, the exit status already says the work is not done (and a sweep resumes the point): a
  // compression that failed is a warning there, the output plain and continuable.
  if (stopped_from_outside && !compress_error.empty()) {
    if (!settings.quiet) log << "capsflow run: warning: " << compress_error << "\n";
    compress_error.clear();
  }
  // A signal during the end phase: the checkpoint and the output are complete; the exit status still says so.
  if (const int sig = stop_signal(); sig != 0 && res.exit_code == 0) {
    res.exit_code = 128 + sig;
    res.stop_message = std::string("interrupted") + signal_label(sig) + " at the end (strain " +
                       strain_text(sim.time()) + "): the output and the checkpoint are complete";
  }
  marker.release();  // a clean end (reached, stopped early or interrupted, each with its checkpoint)

  res.steps = tally.steps;
  res.time = sim.time();
  res.wall_seconds = seconds_since(t_wall);
  if (talk) print_run_summary(log, sim, tally, paths, res.stop_message, res.wall_seconds);
  if (talk) log << compressed_note;
  if (!compress_error.empty()) throw H5Error(compress_error);  // exit 1, after the marker's release and the summary
  return res;
}

int dry_run(const Config& cfg_in, const RunSettings& settings, std::ostream& out) {
  PreparedRun p = prepare_run(cfg_in, settings);
  // "Check everything": the first step too (one velocity evaluation), as the run checks it before its first file.
  {
    Simulation sim = make_simulation(p, settings);
    check_first_step(sim, p, settings);
  }
  const Config& c = p.cfg;
  const RunSize& s = p.size;
  const RunPaths paths = run_paths(p.output_file);
  char line[512];
  out << to_toml(c);
  out << "\n# capsflow run --dry-run: the configuration above is valid";
  if (!settings.restart.empty()) out << " (a continuation of " << settings.restart << ")";
  if (p.start)
    out << " (capsules from " << p.start->file << " frame " << p.start->frame << ", strain "
        << strain_text(p.start->strain) << ")";
  out << "; nothing was written.\n";
  std::snprintf(line, sizeof line,
                "# grid      %d x %d Fourier points, Chebyshev degree %d (%d points across): %llu grid points; "
                "hx = %.4g, hz = %.4g, alpha = %g, cutoff = %g\n",
                s.grid.nx, s.grid.nz, s.grid.ny, s.grid.ny + 1, static_cast<unsigned long long>(s.grid_points),
                s.grid.hx, s.grid.hz, s.grid.alpha, s.grid.cutoff);
  out << line;
  std::snprintf(line, sizeof line, "# capsules  %ld of level %d: %ld nodes; %llu wall points\n", s.capsules,
                c.capsules.mesh_level, s.nodes, static_cast<unsigned long long>(s.wall_points));
  out << line;
  const MemoryLimit avail = available_memory();
  out << "# memory    needs about " << bytes_text(p.memory.total()) << " (grid " << bytes_text(p.memory.grid)
      << ", capsules and wall points " << bytes_text(p.memory.capsules) << ", program " << bytes_text(p.memory.base)
      << "); this process may use " << (avail.bytes ? bytes_text(avail.bytes) + " (" + avail.what + ")" : "(unknown)")
      << "\n";
  if (c.run.backend == Backend::Device) {
    out << "# cost      no estimate for the device backend (its constants are not calibrated yet)\n";
  } else {
    const int threads = c.run.backend == Backend::Serial ? 1 : host_thread_count();
    const CostEstimate e = estimate_cost(c, s, threads);
    std::snprintf(line, sizeof line,
                  "# cost      ESTIMATE (%s, %d thread%s; calibrated on the development machine, docs/performance.md "
                  "section 5): %.2g s per step\n",
                  backend_name(c.run.backend), e.threads, e.threads == 1 ? "" : "s", e.seconds_per_step);
    out << line;
    if (e.interface_solve_applications > 0.0) {
      std::snprintf(line, sizeof line,
                    "#           of which the interface-velocity solve (viscosity ratio != 1: the double layer's "
                    "set_geometry and ~7 GMRES applications, sections 11-12): %.2g s\n",
                    e.seconds_per_step * e.interface_solve_applications / (1.0 + e.interface_solve_applications));
      out << line;
    }
    if (e.dilute && e.steps_per_strain_start > e.steps_per_strain_rule) {
      std::snprintf(line, sizeof line,
                    "#           %.3g steps per strain unit at the start (%.3g s per strain unit), held below the rule "
                    "(step_rule %s: dt = cfl Ca_ref h / a_ref, Ca_ref = %g: %.0f steps per strain unit) by the close "
                    "placement; then the rule's\n",
                    e.steps_per_strain_start, e.seconds_per_strain_start(), step_rule_name(c.time.step_rule), e.ca_ref,
                    e.steps_per_strain_rule);
      out << line;
    } else if (e.dilute) {
      std::snprintf(line, sizeof line,
                    "#           %.0f steps per strain unit (step_rule %s: dt = cfl Ca_ref h / a_ref, Ca_ref = %g, h "
                    "of a lone capsule's mesh): %.3g s per strain unit\n",
                    e.steps_per_strain_start, step_rule_name(c.time.step_rule), e.ca_ref,
                    e.seconds_per_strain_start());
      out << line;
    } else {
      std::snprintf(line, sizeof line,
                    "#           step_rule %s; fresh placement: %.0f steps per strain unit, %.3g s per strain unit; "
                    "developed suspension (%s): %.0f steps, %.3g s per strain unit\n",
                    step_rule_name(c.time.step_rule), e.steps_per_strain_start, e.seconds_per_strain_start(),
                    c.time.step_rule == StepRule::Paper ? "closest nodes near min_gap, ~3x more steps"
                                                        : "pairs within h_e, near_contact_factor applied",
                    e.steps_per_strain_developed, e.seconds_per_strain_developed());
      out << line;
    }
    const double end = c.time.end.value_or(0.0);
    if (e.dilute)
      std::snprintf(line, sizeof line, "#           to end = %g: about %.3g hours%s\n", end, e.total_seconds / 3600.0,
                    c.time.steady_stop || c.time.stop_pair_dx ? " at most (a stop condition may end it earlier)" : "");
    else
      std::snprintf(line, sizeof line,
                    "#           to end = %g: about %.3g hours (the fresh rate for the first %g strain units, then the "
                    "developed one)\n",
                    end, e.total_seconds / 3600.0, std::min(end, 2.0));
    out << line;
  }
  // A first step far below the rule (a close pair with a tiny c_gap, near_contact_factor or min_gap), on every
  // backend: the run would say so after its first steps (StepWatch), the dry run says it now.
  const StartStepEstimate st = start_step_estimate(c);
  if (st.far_below()) {
    std::snprintf(line, sizeof line, "the first steps take dt = %.3g, 1/%.3g of the membrane rule's %.3g", st.dt,
                  st.dt_rule / st.dt, st.dt_rule);
    out << "# WARNING   " << line << " ([time] cfl x Ca_ref x h / a_ref): held by " << st.keys
        << (st.limit == StepLimit::Collision ? " (closing speeds of the imposed flow)" : "");
    std::snprintf(line, sizeof line, "; about %.3g steps per strain unit; ", 1.0 / st.dt);
    out << line << step_limit_advice(c, st.limit) << "\n";
  }
  out << "# output    " << paths.h5.string() << ", " << paths.xdmf.string() << ", " << paths.checkpoint.string();
  if (settings.restart.empty())
    for (const fs::path& f : {paths.h5, paths.xdmf, paths.checkpoint})
      if (fs::exists(f)) {
        out << " (" << f.string() << " exists: a run needs --force)";
        break;
      }
  out << "\n";
  return 0;
}

}  // namespace capsflow
