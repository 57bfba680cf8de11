// What `capsflow run` prints (run_report.hpp): the header, the progress lines and the end-of-run summary.
#include "host/run/run_report.hpp"

#include <filesystem>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ostream>

#include "host/base/atomic_file.hpp"
#include "host/base/backend_select.hpp"
#include "host/base/build_info.hpp"
#include "host/base/device_info.hpp"
#include "host/base/stopwatch.hpp"
#include "kernels/simd_path.hpp"

namespace capsflow {

std::string duration_text(double s) {
  char buf[64];
  if (!std::isfinite(s) || s < 0) return "?";
  if (s < 60) std::snprintf(buf, sizeof buf, "%.0f s", s);
  else if (s < 3600) std::snprintf(buf, sizeof buf, "%d min %02d s", static_cast<int>(s / 60), static_cast<int>(s) % 60);
  else std::snprintf(buf, sizeof buf, "%d h %02d min", static_cast<int>(s / 3600), static_cast<int>(s / 60) % 60);
  return buf;
}

void print_run_header(std::ostream& log, const Simulation& sim, const RunPaths& paths, bool restart, double end) {
  const Config& cfg = sim.config();
  const GgemGrid& g = sim.grid();
  const CapsuleState& s = sim.state();
  log << "capsflow run: " << s.num_capsules() << (s.num_capsules() == 1 ? " capsule (" : " capsules (")
      << s.num_nodes() << " nodes, mesh level " << cfg.capsules.mesh_level << "), H = " << cfg.domain.H
      << ", Lx = " << cfg.domain.Lx << ", Lz = " << cfg.domain.Lz << ", grid " << g.nx << " x " << g.nz << " x "
      << (g.ny + 1) << ", backend " << backend_name(cfg.run.backend);
  if (cfg.run.backend == Backend::Threads) {
    const int n = host_thread_count();
    log << " (" << n << (n == 1 ? " thread)" : " threads)");
  }
  if (cfg.run.backend == Backend::Device) log << " (" << device_description() << ")";
  log << "\n  " << (restart ? "continuing from strain " : "from strain ") << sim.time() << " to " << end
      << "; output " << paths.h5.string() << "\n  build " << build_description();
  // The host loops' instruction set: a continuation on another path differs from the run's own at rounding level.
  if (cfg.run.backend != Backend::Device) log << ", host vector path " << simd_path_name(host_simd_path());
  log << "\n";
  log.flush();
}

ProgressLine::ProgressLine(double every_seconds, double t_start, double end)
    : every_(every_seconds), t_start_(t_start), end_(end), start_(std::chrono::steady_clock::now()), last_(start_) {}

void ProgressLine::step(std::ostream& log, const Simulation& sim, const StepInfo& info, std::int64_t steps_here) {
  contacts_since_ += info.contact.pair_corrections + info.contact.wall_corrections;
  if (every_ <= 0 || seconds_since(last_) < every_) return;
  last_ = std::chrono::steady_clock::now();
  const double el = seconds_since(start_), done = sim.time() - t_start_;
  const double eta = done > 0 ? el / done * (end_ - sim.time()) : -1.0;
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "  strain %.3f / %g (%.1f %%)  step %lld  dt %.3g  contacts %ld (total %ld)  %.3g s/step  ETA %s\n",
                sim.time(), end_, 100.0 * sim.time() / end_, static_cast<long long>(sim.step()), info.dt,
                contacts_since_, sim.total_contact_corrections(), el / static_cast<double>(std::max<std::int64_t>(1, steps_here)),
                duration_text(eta).c_str());
  log << buf;
  log.flush();
  contacts_since_ = 0;
}

void print_run_summary(std::ostream& log, const Simulation& sim, const RunTally& tally, const RunPaths& paths,
                       const std::string& stop_message, double wall_seconds) {
  const Config& cfg = sim.config();
  if (!stop_message.empty()) log << "capsflow run: " << stop_message << "\n";
  const double n = std::max<double>(1.0, static_cast<double>(tally.steps));
  const double per = tally.loop_seconds / n;
  const SimulationTimings& acc = tally.timings;
  char buf[640];
  std::snprintf(buf, sizeof buf,
                "capsflow run: strain %.4g reached in %lld steps (%s, %.3g s/step; %lld steps capped by "
                "max_step_ratio)\n  per step: forces %.3g s, local nodes %.3g s, local walls %.3g s, global %.3g s, "
                "dt %.3g s, contact %.3g s, output %.3g s\n",
                sim.time(), static_cast<long long>(tally.steps), duration_text(wall_seconds).c_str(), per,
                static_cast<long long>(tally.capped_steps), acc.forces / n, acc.local_nodes / n, acc.local_walls / n,
                acc.global / n, acc.step_size / n, acc.contact / n, tally.io_seconds / n);
  log << buf;
  // Contact: KG report "a couple of minimum gap violations per time unit" for 50 capsules.
  const double span = sim.time() - tally.t_start;
  const long ev = sim.total_contact_events() - tally.events_start;
  std::snprintf(buf, sizeof buf,
                "  contact    %ld events in this part (%.3g per strain unit), %ld pushes in %ld steps over the run%s\n",
                ev, span > 0 ? static_cast<double>(ev) / span : 0.0, sim.total_contact_corrections(),
                sim.steps_with_contacts(), sim.unconverged_contacts() ? " (some did not converge)" : "");
  log << buf;
  if (span > 0 && tally.steps > 0) {
    // The step rule's account (docs/method.md section 4.1): how many steps a strain unit took and what bound them;
    // the contact control's share of the cross-stream motion (|dy| per capsule per strain unit).
    const double ns = static_cast<double>(tally.steps);
    auto share = [&](StepLimit l) { return 100.0 * static_cast<double>(tally.limits[static_cast<std::size_t>(l)]) / ns; };
    std::snprintf(buf, sizeof buf,
                  "  steps      %.4g per strain unit (rule %s); bound by membrane %.1f %%, near-contact %.1f %%, "
                  "collision cap %.1f %%, ratio cap %.1f %%, paper gap %.1f %%; contact |dy| %.3g per capsule per "
                  "strain unit\n",
                  ns / span, step_rule_name(cfg.time.step_rule), share(StepLimit::Membrane),
                  share(StepLimit::NearContact), share(StepLimit::Collision), share(StepLimit::Ratio),
                  share(StepLimit::PaperGap), tally.contact_dy / (span * sim.state().num_capsules()));
    log << buf;
  }
  if (tally.gmres.steps > 0) {
    std::snprintf(buf, sizeof buf,
                  "  gmres      %.3g operator applications per step (mean), %lld at most; largest final residual %.3g "
                  "([gmres] tolerance %.3g); interface solve %.3g s/step\n",
                  static_cast<double>(tally.gmres.iterations) / static_cast<double>(tally.gmres.steps),
                  static_cast<long long>(tally.gmres.max_iterations), tally.gmres.max_residual, cfg.gmres.tolerance,
                  acc.interface_solve / n);
    log << buf;
  }
  if (tally.flow_records > 0 && cfg.flow.type != FlowType::None) {
    std::snprintf(buf, sizeof buf, "  flow       %s %.6g (mean over %lld records of this part)\n",
                  cfg.flow.type == FlowType::Poiseuille ? "Q / Q_0" : "relative viscosity",
                  tally.flow_sum / static_cast<double>(tally.flow_records), static_cast<long long>(tally.flow_records));
    log << buf;
  }

  // Per species: where the capsules are across the slit, how deformed, how fast, and their volumes.
  const CapsuleGeometry g = sim.geometry();
  const auto& U = sim.capsule_velocity();
  const auto& V0 = sim.initial_volumes();
  double worst = 0.0;
  int worst_k = -1;
  log << "  species     capsules   |y_c/H - 1/2| start -> now   Taylor D   U_x / (gammadot a)   V/V0 min .. max\n";
  for (std::size_t sp = 0; sp < cfg.species.size(); ++sp) {
    double y0 = 0, y1 = 0, D = 0, ux = 0, vmin = INFINITY, vmax = -INFINITY;
    int count = 0;
    for (int k = 0; k < sim.state().num_capsules(); ++k) {
      if (sim.state().species_of(k) != static_cast<int>(sp)) continue;
      const std::size_t kk = static_cast<std::size_t>(k);
      ++count;
      const double H = cfg.domain.H;
      y0 += std::abs(sim.placements()[kk].center[1] / H - 0.5);
      y1 += std::abs(g.centroid[3 * kk + 1] / H - 0.5);
      D += g.deformation[kk].D;
      if (sim.evaluated()) ux += U[3 * kk];
      const double r = g.volume[kk] / V0[kk];
      vmin = std::min(vmin, r);
      vmax = std::max(vmax, r);
      if (std::abs(r - 1.0) > worst) {
        worst = std::abs(r - 1.0);
        worst_k = k;
      }
    }
    if (count == 0) continue;
    std::snprintf(buf, sizeof buf, "  %-10s %9d         %8.4f -> %-8.4f       %8.3f   %8.3f             %.6f .. %.6f\n",
                  cfg.species[sp].name.c_str(), count, y0 / count, y1 / count, D / count,
                  ux / count / (cfg.flow.shear_rate * cfg.capsules.radius), vmin, vmax);
    log << buf;
  }
  if (worst > 1e-3) {
    std::snprintf(buf, sizeof buf,
                  "  warning: capsule %d's volume is %.4g %% off its initial value (more than 0.1 %%): check "
                  "[capsules] velocity_projection / volume_correction and the mesh\n",
                  worst_k, 100.0 * worst);
    log << buf;
  }
  log << "  output     " << paths.h5.string() << " (HDF5: /series, /frames, /events; docs/output_format.md)\n"
      << "  ParaView   " << paths.xdmf.string() << "\n";
  log << "  figures    capsflow figures " << paths.h5.string()
      << " --out DIR (the run's diagnostics: heights, D, volume, dt, contacts)\n";
  log << "  checkpoint " << paths.checkpoint.string() << "\n";
  log.flush();
}

}  // namespace capsflow
