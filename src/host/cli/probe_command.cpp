// The implementation of probe_command.hpp: `capsflow probe`, the measured stability limit of the explicit step.
#include "host/cli/probe_command.hpp"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include "host/base/atomic_file.hpp"
#include "host/base/errors.hpp"
#include "host/base/printable.hpp"
#include "host/physics/config.hpp"
#include "host/physics/simulation.hpp"
#include "host/physics/stability_probe.hpp"
#include "host/physics/step_watch.hpp"

namespace capsflow {

namespace {

std::string num(double v) { return format_significant(v, 4); }

}  // namespace

CLI::App* add_probe(CLI::App& app, ProbeOptions& o) {
  CLI::App* p = app.add_subcommand(
      "probe", "Measure the largest stable step of the explicit membrane step at a configuration's initial state (the "
               "stability probe: docs/method.md 4.1) and compare it with the step its [time] cfl chooses");
  p->add_option("CONFIG", o.config, "The run's configuration (TOML)")->required()->type_name("CONFIG");
  p->add_option("--set", o.sets, "Override a configuration key (repeatable), as for capsflow run: section.key=value")
      ->type_name("KEY=VALUE")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  p->add_option("--out", o.out, "Also write the measurement to FILE (JSON)")
      ->type_name("FILE")
      ->check(CLI::Validator(
          [](std::string& v) { return v.empty() ? std::string("expected a file name, got an empty string") : ""; }, "",
          "non-empty"));
  p->add_flag("--force", o.force, "Replace FILE if it exists");
  p->add_option("--iterations", o.iterations, "Arnoldi steps (velocity evaluations after the first)")
      ->check(CLI::Range(2, 1000))
      ->capture_default_str();
  p->footer("Exit status: 0 measured (a chosen step above the limit is said, not an error), 2 input error.");
  return p;
}

int run_probe(const ProbeOptions& o, std::ostream& out) {
  Config cfg = load_config(o.config, parse_overrides(o.sets));
  if (!cfg.time.end) cfg.time.end = 1.0;  // the probe takes no step of the run: [time] end is not needed
  // velocities_at runs on the host backends only.
  const bool was_device = cfg.run.backend == Backend::Device;
  if (was_device) cfg.run.backend = Backend::Threads;
  validate_run_config(cfg);
  if (!o.out.empty()) {
    if (std::filesystem::path(o.out).filename().empty())
      throw InputError("--out: expected a file name (FILE.json), got \"" + o.out + "\"");
    ensure_can_create(o.out, o.force);
    check_not_an_input(o.out, {{o.config, "configuration"}});
  }

  Simulation sim(cfg);
  // What `capsflow run` refuses, the probe refuses the same way (run_driver's first-step check): values that pass each
  // key's range but give no step (inflation 1e300 measured 'lambda 4.6e-310, residual nan, cfl <= inf').
  if (const std::string why = sim.next_step_problem(); !why.empty()) throw InputError(cfg.source + ": " + why);
  sim.evaluate();
  StabilityProbeOptions po;
  po.iterations = o.iterations;
  const StabilityEstimate e = probe_stability(sim, po);
  // The probe's limit in the rule's units: dt = cfl Ca_ref h / a_ref (step_rule.hpp's membrane_step) against its
  // tau = cfl_crit Ca_ref h.
  const StepScales rule = step_scales(cfg);
  const double a_ref = rule.a_ref;
  const double dt_limit = e.cfl_crit * e.ca * e.h, cfl_limit = e.cfl_crit * a_ref;
  // The step the run takes first (the rule, the near-contact factor, the collision cap, bending), from the same state.
  const StepInfo first = sim.advance();
  const std::string held = step_limit_keys(cfg, first, sim.near_contact_range());
  const double share = first.dt / dt_limit;

  const long nodes = static_cast<long>(sim.state().x.size());
  const int capsules = sim.state().num_capsules();
  out << "capsflow probe: " << o.config << ": " << capsules << (capsules == 1 ? " capsule, " : " capsules, ") << nodes
      << " nodes, at the initial state" << (was_device ? " (on the host: threads backend)" : "") << "; "
      << e.evaluations << " velocity evaluations\n";
  out << "  fastest mode     lambda = " << num(e.lambda_re) << (e.lambda_im < 0 ? " - " : " + ")
      << num(std::abs(e.lambda_im)) << "i per strain unit (Ritz residual " << num(e.ritz_residual) << ")\n";
  out << "  measured limit   dt <= " << num(dt_limit) << " strain units: [time] cfl <= " << num(cfl_limit)
      << " (dt = cfl Ca_ref h / a_ref, Ca_ref = " << num(e.ca) << ", h = " << num(e.h) << ", a_ref = " << num(a_ref)
      << ")\n";
  // A membrane's modes decay: a growing Ritz value is not one, but a finite difference across a jump of the velocity
  // (a node on a switch of the interpolation stencil: probe_stability measures again with a larger step, and says
  // so); one that still grows then says nothing about the limit.
  const bool growing = e.lambda_re > 0.0;
  if (e.discarded_growth > 0.0)
    out << "  note: measured with a finite-difference step of " << num(e.rms_displacement)
        << " a (rms node displacement): at the default step the top Ritz value grew (" << num(e.discarded_growth)
        << " per strain unit), a node crossing a switch of the interpolation stencil (the velocity jumps there by "
           "the interpolation's error; at mid-channel when the Chebyshev degree is odd)\n";
  const bool stopped = first.stop != StopReason::None;  // the run would stop at once: said, no comparison
  if (stopped) {
    out << "  chosen           the first step stopped: " << first.message << "\n";
  } else {
    out << "  chosen           dt = " << num(first.dt) << " strain units ([time] cfl = " << num(rule.cfl)
        << (held.empty() ? std::string(", the step rule") : ", held by " + held) << "): " << num(share)
        << " of the measured limit\n";
    if (growing)
      out << "  note: the fastest Ritz value grows (Re lambda > 0), which no membrane relaxation mode does, also "
             "with a finite-difference step 100 times the default: the finite difference met a jump of the velocity, "
             "not the membrane's stiffness; this limit does not apply\n";
    else if (share > 1.0)
      out << "  warning: the chosen step is above the measured limit: the run would go unstable; lower [time] cfl "
             "to at most "
          << num(rule.cfl / share) << "\n";
  }

  if (!o.out.empty()) {
    nlohmann::ordered_json j;
    j["config"] = o.config;
    j["capsules"] = capsules;
    j["nodes"] = nodes;
    j["evaluations"] = e.evaluations;
    j["lambda_re"] = e.lambda_re;
    j["lambda_im"] = e.lambda_im;
    j["ritz_residual"] = e.ritz_residual;
    j["ca_ref"] = e.ca;
    j["h"] = e.h;
    j["a_ref"] = a_ref;
    j["dt_limit"] = dt_limit;
    j["cfl_limit"] = cfl_limit;
    j["cfl"] = rule.cfl;
    j["dt_chosen"] = stopped ? 0.0 : first.dt;
    j["first_step_stopped"] = first.message;  // empty unless the first step stopped
    j["chosen_over_limit"] = share;
    j["growing_mode"] = growing;  // true: the limit does not apply (see the note above)
    j["rms_displacement"] = e.rms_displacement;  // the finite-difference step of the measurement
    j["discarded_growth"] = e.discarded_growth;  // > 0: the growing top value at the default step, set aside
    write_file_atomically(o.out, j.dump(2) + "\n");
  }
  return 0;
}

}  // namespace capsflow
