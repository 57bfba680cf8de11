#include "host/run_driver.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <ostream>
#include <memory>
#include <optional>
#include <random>
#include <sstream>

#include "capsflow_version.hpp"
#include "host/atomic_file.hpp"
#include "host/backend_select.hpp"
#include "host/errors.hpp"
#include "host/h5_file.hpp"
#include "host/simulation.hpp"
#include "host/stopwatch.hpp"
#include "host/svg_plot.hpp"
#include "host/xdmf_writer.hpp"

namespace capsflow {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------------------------------
// Signals

namespace {
volatile std::sig_atomic_t g_stop_signal = 0;

extern "C" void capsflow_stop_handler(int sig) { g_stop_signal = sig; }
}  // namespace

void install_stop_signal_handlers() {
  struct sigaction sa {};
  sa.sa_handler = capsflow_stop_handler;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESETHAND;  // a second signal takes the default action (kills)
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}
int stop_signal() { return static_cast<int>(g_stop_signal); }
void request_stop(int signal) { g_stop_signal = signal; }
void clear_stop_request() { g_stop_signal = 0; }

// ---------------------------------------------------------------------------------------------------------

std::string embedded_demo_config() {
  return R"(# capsflow run's embedded demo: 8 capsules, 4 stiff (Ca = 0.2) and 4 floppy (Ca = 1), in pressure-driven flow
# through a slit of width H = 8a, all starting at 0.6a from a wall. The walls push deformed capsules toward the
# centreline (wall-induced migration); floppy capsules deform more and leave the walls faster. Segregation by
# rigidity (Kumar & Graham) starts from this difference.
[domain]
H = 8.0
Lx = 8.0
Lz = 8.0

[ggem]
alpha = 4.0
alpha_hm = 0.5

[run]
backend = "threads"

[flow]
type = "poiseuille"
shear_rate = 1.0

[capsules]
mesh_level = 2
inflation = 0.1
# At mesh level 2 a pre-inflated stiff capsule loses ~1 % of its volume per strain unit to discretisation error
# (docs/method.md section 3, docs/validation.md section 3); the demo restores it every step (D11's option).
volume_correction = true

[[species]]
name = "stiff"
ca = 0.2

[[species]]
name = "floppy"
ca = 1.0

[[capsule]]
species = "stiff"
center = [2.0, 1.6, 2.0]
[[capsule]]
species = "floppy"
center = [6.0, 1.6, 2.0]
[[capsule]]
species = "floppy"
center = [2.0, 1.6, 6.0]
[[capsule]]
species = "stiff"
center = [6.0, 1.6, 6.0]
[[capsule]]
species = "stiff"
center = [0.0, 6.4, 4.0]
[[capsule]]
species = "stiff"
center = [4.0, 6.4, 0.0]
[[capsule]]
species = "floppy"
center = [4.0, 6.4, 4.0]
[[capsule]]
species = "floppy"
center = [0.0, 6.4, 0.0]

[time]
end = 40.0

[output]
file = "capsflow-run-demo/demo.h5"
every = 0.1
frames_every = 0.5
checkpoint_every = 5.0
)";
}

namespace {

struct OutputPaths {
  fs::path h5, xdmf, checkpoint, plot;
};

OutputPaths output_paths(const std::string& file) {
  OutputPaths p;
  p.h5 = fs::path(file);
  p.xdmf = p.h5;
  p.xdmf.replace_extension(".xdmf");
  const std::string stem = p.h5.stem().string();
  p.checkpoint = p.h5.parent_path() / (stem + ".checkpoint.h5");
  p.plot = p.h5.parent_path() / (stem + ".trajectories.svg");
  return p;
}

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

std::string duration_text(double s) {
  char buf[64];
  if (!std::isfinite(s) || s < 0) return "?";
  if (s < 60) std::snprintf(buf, sizeof buf, "%.0f s", s);
  else if (s < 3600) std::snprintf(buf, sizeof buf, "%d min %02d s", static_cast<int>(s / 60), static_cast<int>(s) % 60);
  else std::snprintf(buf, sizeof buf, "%d h %02d min", static_cast<int>(s / 3600), static_cast<int>(s / 60) % 60);
  return buf;
}

// Schedule of the output, carried in the checkpoint.
struct Schedule {
  double next_record = 0.0, next_frame = 0.0, next_checkpoint = 0.0;
  std::int64_t records = 0, frames = 0;
};

class RunOutput {
 public:
  RunOutput(const OutputPaths& paths, const Simulation& sim, std::string run_id, bool create, bool force,
            const Schedule& sched)
      : paths_(paths), run_id_(std::move(run_id)) {
    const CapsuleState& s = sim.state();
    const std::size_t nn = static_cast<std::size_t>(s.num_nodes());
    XdmfSeries xs;
    xs.h5_file_name = paths.h5.filename().string();
    xs.triangles = {"/mesh/triangles_all",
                    {static_cast<std::size_t>(s.num_capsules()) * s.triangles_per_capsule(), 3},
                    XdmfNumber::Int32};
    xs.positions_path = "/frames/positions";
    xs.n_nodes = nn;
    xs.attributes.push_back({"species", XdmfCenter::Node, {"/mesh/node_species", {nn}, XdmfNumber::Int32}, false});
    xs.attributes.push_back({"capsule", XdmfCenter::Node, {"/mesh/node_capsule", {nn}, XdmfNumber::Int32}, false});
    xs.attributes.push_back(
        {"velocity", XdmfCenter::Node, {"/frames/velocity", {nn, 3}, XdmfNumber::Float64}, true});
    if (create) {
      h5_.emplace(H5File::create(paths.h5, force));
      write_static(sim);
      xdmf_ = std::make_unique<XdmfWriter>(paths.xdmf, xs);
    } else {
      h5_.emplace(H5File::open(paths.h5, H5Access::ReadWrite));
      const std::string id =
          h5_->has_attribute("/", "run_id") ? h5_->attribute<std::string>("/", "run_id") : std::string("<none>");
      if (id != run_id_)
        throw InputError(paths.h5.string() + ": belongs to another run (run_id " + id +
                         ") than the checkpoint (run_id " + run_id_ + "); pass the right file with --output");
      // Drop what was written after the checkpoint: the continued run writes it again, identically.
      for (const char* p : kSeries)
        if (h5_->exists(p)) h5_->truncate(p, static_cast<std::size_t>(sched.records));
      for (const char* p : {"/frames/time", "/frames/positions", "/frames/velocity"})
        if (h5_->exists(p)) h5_->truncate(p, static_cast<std::size_t>(sched.frames));
      xdmf_ = std::make_unique<XdmfWriter>(paths.xdmf, xs);
      std::vector<double> times;
      if (h5_->exists("/frames/time")) times = h5_->read<double>("/frames/time").data;
      xdmf_->set_frame_times(times);
      h5_->flush();
    }
  }

  void record(const Simulation& sim) {
    const CapsuleGeometry g = sim.geometry();
    const std::size_t np = static_cast<std::size_t>(sim.state().num_capsules());
    const double t = sim.time(), dt = sim.last_dt();
    const std::int64_t step = sim.step(), contacts = sim.total_contact_corrections();
    std::vector<double> D(np), incl(np);
    for (std::size_t k = 0; k < np; ++k) {
      D[k] = g.deformation[k].D;
      incl[k] = g.deformation[k].inclination;
    }
    const std::vector<double> c = sim.unwrapped_centroids(g);
    h5_->append("/series/time", &t, {});
    h5_->append("/series/step", &step, {});
    h5_->append("/series/dt", &dt, {});
    h5_->append("/series/contact_corrections", &contacts, {});
    h5_->append("/series/centroid", c.data(), {np, 3});
    h5_->append("/series/velocity", sim.capsule_velocity().data(), {np, 3});
    h5_->append("/series/taylor_D", D.data(), {np});
    h5_->append("/series/inclination", incl.data(), {np});
    h5_->append("/series/volume", g.volume.data(), {np});
    h5_->append("/series/area", g.area.data(), {np});
    h5_->flush();
  }

  void frame(const Simulation& sim) {
    const CapsuleState& s = sim.state();
    const std::size_t nn = static_cast<std::size_t>(s.num_nodes());
    std::vector<double> p(3 * nn), u(3 * nn);
    for (std::size_t i = 0; i < nn; ++i) {
      p[3 * i] = s.x[i];
      p[3 * i + 1] = s.y[i];
      p[3 * i + 2] = s.z[i];
      u[3 * i] = sim.ux()[i];
      u[3 * i + 1] = sim.uy()[i];
      u[3 * i + 2] = sim.uz()[i];
    }
    const double t = sim.time();
    h5_->append("/frames/time", &t, {});
    h5_->append("/frames/positions", p.data(), {nn, 3});
    h5_->append("/frames/velocity", u.data(), {nn, 3});
    h5_->flush();  // before the index that lists the frame
    xdmf_->add_frame(t);
  }

  void close() { h5_->close(); }

 private:
  static constexpr const char* kSeries[] = {
      "/series/time",   "/series/step",     "/series/dt",        "/series/contact_corrections",
      "/series/centroid", "/series/velocity", "/series/taylor_D", "/series/inclination",
      "/series/volume", "/series/area"};

  void write_static(const Simulation& sim) {
    const Config& cfg = sim.config();
    const CapsuleState& s = sim.state();
    const GgemGrid& grid = sim.velocity_solver().ggem().grid();
    h5_->set_attribute("/", "capsflow_version", CAPSFLOW_VERSION_STRING);
    h5_->set_attribute("/", "run_id", run_id_);
    h5_->set_attribute("/", "units", "lengths in units of the capsule radius a's unit; time in strain units 1/gammadot");
    h5_->write_string("/parameters/config", to_toml(cfg));
    h5_->set_attribute("/parameters", "source", cfg.source);
    h5_->set_attribute("/parameters", "grid_nx", static_cast<std::int64_t>(grid.nx));
    h5_->set_attribute("/parameters", "grid_nz", static_cast<std::int64_t>(grid.nz));
    h5_->set_attribute("/parameters", "grid_ny", static_cast<std::int64_t>(grid.ny));
    h5_->set_attribute("/parameters", "cutoff", grid.cutoff);
    h5_->set_attribute("/parameters", "threads",
                      static_cast<std::int64_t>(cfg.run.backend == Backend::Serial ? 1 : host_thread_count()));

    const int np = s.num_capsules(), nv = s.nodes_per_capsule(), nt = s.triangles_per_capsule();
    const std::vector<int>& tri = s.mesh().tri;
    std::vector<std::int32_t> t_local(tri.begin(), tri.end()), t_all(3 * static_cast<std::size_t>(np) * nt);
    for (int k = 0; k < np; ++k)
      for (int e = 0; e < 3 * nt; ++e) t_all[3 * static_cast<std::size_t>(k) * nt + e] = tri[e] + k * nv;
    h5_->write("/mesh/triangles", {static_cast<std::size_t>(nt), 3}, t_local);
    h5_->set_attribute("/mesh/triangles", "mesh_level", static_cast<std::int64_t>(cfg.capsules.mesh_level));
    h5_->write("/mesh/triangles_all", {static_cast<std::size_t>(np) * nt, 3}, t_all);
    std::vector<std::int32_t> node_species(static_cast<std::size_t>(np) * nv), node_capsule(node_species.size());
    std::vector<std::int32_t> species(np), pinned(np);
    std::vector<double> ca(np);
    for (int k = 0; k < np; ++k) {
      species[k] = s.species_of(k);
      ca[k] = cfg.species[static_cast<std::size_t>(s.species_of(k))].ca;
      pinned[k] = sim.pinned()[k];
      for (int i = 0; i < nv; ++i) {
        node_species[static_cast<std::size_t>(k) * nv + i] = species[k];
        node_capsule[static_cast<std::size_t>(k) * nv + i] = k;
      }
    }
    h5_->write("/mesh/node_species", {node_species.size()}, node_species);
    h5_->write("/mesh/node_capsule", {node_capsule.size()}, node_capsule);
    h5_->write("/capsules/species", {static_cast<std::size_t>(np)}, species);
    h5_->write("/capsules/ca", {static_cast<std::size_t>(np)}, ca);
    h5_->write("/capsules/pinned", {static_cast<std::size_t>(np)}, pinned);
    std::string names;
    for (const SpeciesSpec& sp : cfg.species) names += (names.empty() ? "" : ",") + sp.name;
    h5_->set_attribute("/capsules/species", "names", names);
    h5_->set_attribute("/capsules", "radius", cfg.capsules.radius);
    h5_->flush();
  }

  OutputPaths paths_;
  std::string run_id_;
  std::optional<H5File> h5_;
  std::unique_ptr<XdmfWriter> xdmf_;
};

// Distance of the capsule centres from the nearest wall against strain: thin lines per capsule, a thick dashed line
// per species for its mean. Wall-induced migration and its dependence on rigidity are what a reader wants first.
void write_trajectory_plot(const fs::path& h5_path, const fs::path& svg_path, const Config& cfg) {
  H5File f = H5File::open(h5_path);
  if (!f.exists("/series/time")) return;
  const auto t = f.read<double>("/series/time");
  const auto c = f.read<double>("/series/centroid");
  const auto sp = f.read<std::int32_t>("/capsules/species");
  const std::size_t nt = t.data.size(), np = sp.data.size(), ns = cfg.species.size();
  const double H = cfg.domain.H;
  static const char* colors[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b"};
  std::vector<PlotSeries> series, means(ns);
  std::vector<int> count(ns, 0);
  for (std::size_t s = 0; s < ns; ++s) {
    char ca[32];
    std::snprintf(ca, sizeof ca, "%g", cfg.species[s].ca);
    means[s].label = cfg.species[s].name + " (Ca " + ca + "), mean";
    means[s].color = colors[s % 6];
    means[s].dashed = true;
    means[s].x = t.data;
    means[s].y.assign(nt, 0.0);
  }
  for (std::size_t k = 0; k < np; ++k) {
    const auto s = static_cast<std::size_t>(sp.data[k]);
    ++count[s];
    PlotSeries ps;
    ps.color = colors[s % 6];
    for (std::size_t r = 0; r < nt; ++r) {
      const double y = c.data[(r * np + k) * 3 + 1];
      const double d = std::min(y, H - y) / H;
      ps.x.push_back(t.data[r]);
      ps.y.push_back(d);
      means[s].y[r] += d;
    }
    series.push_back(std::move(ps));
  }
  for (std::size_t s = 0; s < ns; ++s) {
    if (count[s] == 0) continue;
    for (double& v : means[s].y) v /= count[s];
    series.push_back(means[s]);
  }
  write_file_atomically(svg_path, svg_line_plot("Distance of the capsule centres from the nearest wall (" +
                                                    cfg.source + ")",
                                                "strain (gammadot t)", "min(y_c, H - y_c) / H", series));
}

}  // namespace

RunResult run_simulation(const Config& cfg_in, const RunSettings& settings, std::ostream& log) {
  const auto t_wall = std::chrono::steady_clock::now();
  const bool restart = !settings.restart.empty();
  Config cfg = cfg_in;
  std::optional<H5File> ck;
  std::string run_id;
  Schedule sched;
  std::string output_file;
  if (restart) {
    ck.emplace(H5File::open(settings.restart));
    if (!ck->exists("/parameters/config") || !ck->exists("/state/positions"))
      throw InputError(settings.restart + ": not a capsflow checkpoint (no /parameters/config or /state)");
    cfg = parse_config(ck->read_string("/parameters/config"), settings.restart + ":/parameters/config");
    run_id = ck->attribute<std::string>("/", "run_id");
    output_file = ck->attribute<std::string>("/", "output_file");
    sched.next_record = ck->attribute<double>("/run", "next_record");
    sched.next_frame = ck->attribute<double>("/run", "next_frame");
    sched.next_checkpoint = ck->attribute<double>("/run", "next_checkpoint");
    sched.records = ck->attribute<std::int64_t>("/run", "records");
    sched.frames = ck->attribute<std::int64_t>("/run", "frames");
  } else {
    run_id = make_run_id();
    output_file = cfg.output.file;
  }
  if (!settings.output.empty()) output_file = settings.output;
  if (settings.end) {
    if (!(*settings.end > 0.0)) throw InputError("--end: expected a number > 0 (strain units)");
    cfg.time.end = *settings.end;
  }
  std::string backend_from = cfg.source + ": [run] backend";
  if (settings.backend) {
    cfg.run.backend = parse_backend(*settings.backend, "--backend");
    backend_from = "--backend";
  }
  if (settings.threads) {
    if (*settings.threads < 0) throw InputError("--threads: expected an integer >= 0");
    cfg.run.threads = *settings.threads;
  }
  cfg.output.file = output_file;
  validate_run_config(cfg);
  try {
    require_backend(cfg.run.backend);
  } catch (const BackendUnavailable& e) {
    throw BackendUnavailable(backend_from + ": " + e.what());
  }
  if (cfg.run.backend == Backend::Threads) set_host_threads(cfg.run.threads);

  const OutputPaths paths = output_paths(output_file);
  if (!restart) {
    // Fail in the first second, before any computing, if an output could not be written.
    for (const fs::path& p : {paths.h5, paths.xdmf, paths.checkpoint, paths.plot}) ensure_can_create(p, settings.force);
  } else if (!fs::exists(paths.h5)) {
    throw InputError(paths.h5.string() + ": the output file of the checkpointed run does not exist (pass it with "
                     "--output)");
  }

  Simulation sim = restart ? Simulation(cfg, *ck) : Simulation(cfg);
  if (ck) ck->close();
  RunOutput out(paths, sim, run_id, !restart, settings.force, sched);

  const double end = *cfg.time.end;
  const bool talk = !settings.quiet;
  RunResult res;
  res.output = paths.h5.string();
  res.xdmf = paths.xdmf.string();
  res.checkpoint = paths.checkpoint.string();

  auto checkpoint = [&]() {
    write_checkpoint_atomically(paths.checkpoint, [&](H5File& f) {
      f.set_attribute("/", "capsflow_version", CAPSFLOW_VERSION_STRING);
      f.set_attribute("/", "run_id", run_id);
      f.set_attribute("/", "output_file", fs::absolute(paths.h5).string());
      f.write_string("/parameters/config", to_toml(cfg));
      f.create_group("/run");
      f.set_attribute("/run", "next_record", sched.next_record);
      f.set_attribute("/run", "next_frame", sched.next_frame);
      f.set_attribute("/run", "next_checkpoint", sched.next_checkpoint);
      f.set_attribute("/run", "records", sched.records);
      f.set_attribute("/run", "frames", sched.frames);
      sim.write_state(f);
    });
  };

  if (talk) {
    const GgemGrid& g = sim.velocity_solver().ggem().grid();
    const CapsuleState& s = sim.state();
    log << "capsflow run: " << s.num_capsules() << " capsules (" << s.num_nodes() << " nodes, mesh level "
        << cfg.capsules.mesh_level << "), H = " << cfg.domain.H << ", Lx = " << cfg.domain.Lx
        << ", Lz = " << cfg.domain.Lz << ", grid " << g.nx << " x " << g.nz << " x " << (g.ny + 1) << ", backend "
        << backend_name(cfg.run.backend);
    if (cfg.run.backend == Backend::Threads) log << " (" << host_thread_count() << " threads)";
    log << "\n  " << (restart ? "continuing from strain " : "from strain ") << sim.time() << " to " << end
        << "; output " << paths.h5.string() << "\n";
    log.flush();
  }

  SimulationTimings acc;
  double t_io = 0.0;
  const double t_start = sim.time();
  auto last_progress = std::chrono::steady_clock::now();
  const auto t_loop = last_progress;
  long contacts_since = 0;
  std::int64_t steps = 0;

  for (;;) {
    sim.evaluate();
    const auto t0 = std::chrono::steady_clock::now();
    const double t = sim.time();
    if (due(t, sched.next_record)) {
      out.record(sim);
      ++sched.records;
      sched.next_record = next_multiple(t, cfg.output.every);
    }
    if (due(t, sched.next_frame)) {
      out.frame(sim);
      ++sched.frames;
      sched.next_frame = next_multiple(t, cfg.output.frames_every);
    }
    if (due(t, end)) break;
    if (due(t, sched.next_checkpoint)) {
      sched.next_checkpoint = next_multiple(t, cfg.output.checkpoint_every);
      if (t > t_start || !restart) checkpoint();
    }
    t_io += seconds_since(t0);

    const int sig = stop_signal();
    if (sig != 0 || (settings.stop_after_steps >= 0 && steps >= settings.stop_after_steps)) {
      checkpoint();
      res.exit_code = sig != 0 ? 128 + sig : 128 + SIGINT;
      res.stop_message = std::string("interrupted") + (sig == SIGTERM ? " (SIGTERM)" : sig ? " (SIGINT)" : "") +
                         " at strain " + std::to_string(t) + "; continue with: capsflow run --restart " +
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
    ++steps;
    acc += sim.last_timings();
    contacts_since += info.contact.pair_corrections + info.contact.wall_corrections;

    if (talk && settings.progress_seconds > 0 && seconds_since(last_progress) >= settings.progress_seconds) {
      last_progress = std::chrono::steady_clock::now();
      const double el = seconds_since(t_loop), done = sim.time() - t_start;
      const double eta = done > 0 ? el / done * (end - sim.time()) : -1.0;
      char buf[256];
      std::snprintf(buf, sizeof buf,
                    "  strain %.3f / %g (%.1f %%)  step %lld  dt %.3g  contacts %ld (total %ld)  %.3g s/step  "
                    "ETA %s\n",
                    sim.time(), end, 100.0 * sim.time() / end, static_cast<long long>(sim.step()), info.dt,
                    contacts_since, sim.total_contact_corrections(), el / static_cast<double>(steps),
                    duration_text(eta).c_str());
      log << buf;
      log.flush();
      contacts_since = 0;
    }
  }
  if (res.exit_code == 0) checkpoint();
  out.close();
  write_trajectory_plot(paths.h5, paths.plot, cfg);

  res.steps = steps;
  res.time = sim.time();
  res.wall_seconds = seconds_since(t_wall);
  if (talk) {
    if (!res.stop_message.empty()) log << "capsflow run: " << res.stop_message << "\n";
    const double n = std::max<double>(1.0, static_cast<double>(steps));
    const double per = seconds_since(t_loop) / n;
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "capsflow run: strain %.4g reached in %lld steps (%s, %.3g s/step); contact corrections %ld in "
                  "%ld steps%s\n  per step: forces %.3g s, local nodes %.3g s, local walls %.3g s, global %.3g s, "
                  "dt %.3g s, contact %.3g s, output %.3g s\n",
                  sim.time(), static_cast<long long>(steps), duration_text(res.wall_seconds).c_str(), per,
                  sim.total_contact_corrections(), sim.steps_with_contacts(),
                  sim.unconverged_contacts() ? " (some did not converge)" : "", acc.forces / n, acc.local_nodes / n,
                  acc.local_walls / n, acc.global / n, acc.step_size / n, acc.contact / n, t_io / n);
    log << buf;
    // Per species: where the capsules are across the slit, how deformed, how fast (the demo's result at a glance).
    const CapsuleGeometry g = sim.geometry();
    const auto& U = sim.capsule_velocity();
    log << "  species     capsules   |y_c/H - 1/2| start -> now   Taylor D   U_x / (gammadot a)   (means)\n";
    for (std::size_t sp = 0; sp < cfg.species.size(); ++sp) {
      double y0 = 0, y1 = 0, D = 0, ux = 0;
      int count = 0;
      for (int k = 0; k < sim.state().num_capsules(); ++k) {
        if (sim.state().species_of(k) != static_cast<int>(sp)) continue;
        ++count;
        const double H = cfg.domain.H;
        y0 += std::abs(sim.placements()[static_cast<std::size_t>(k)].center[1] / H - 0.5);
        y1 += std::abs(g.centroid[3 * static_cast<std::size_t>(k) + 1] / H - 0.5);
        D += g.deformation[static_cast<std::size_t>(k)].D;
        if (sim.evaluated()) ux += U[3 * static_cast<std::size_t>(k)];
      }
      if (count == 0) continue;
      std::snprintf(buf, sizeof buf, "  %-10s %9d         %8.4f -> %-8.4f       %8.3f   %8.3f\n",
                    cfg.species[sp].name.c_str(), count, y0 / count, y1 / count, D / count,
                    ux / count / (cfg.flow.shear_rate * cfg.capsules.radius));
      log << buf;
    }
    log << "  output     " << paths.h5.string() << " (HDF5: /series, /frames; docs/usage.md)\n"
        << "  ParaView   " << paths.xdmf.string() << "\n"
        << "  plot       " << paths.plot.string() << "\n"
        << "  checkpoint " << paths.checkpoint.string() << "\n";
    log.flush();
  }
  return res;
}

}  // namespace capsflow
