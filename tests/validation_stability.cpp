// The stability probe of the membrane step rule (label 'validation'; docs/method.md section 4.1, docs/validation.md
// section 9). For each configuration of the step-rule issue it measures the largest stable cfl of AB2 (Arnoldi on
// the finite-difference Jacobian of the projected node velocities, host/physics/stability_probe.hpp) and checks the
// step the study's presets choose (their [time] cfl, 0.6 since issue 34, read from examples/presets/set_a.toml; the
// code's default 0.5 is below it) against it:
//   - the chosen step, cfl (times near_contact_factor while a pair is closer than h_e), is at most 0.8 of the
//     measured limit;
//   - a fixed-step run at the chosen step from a 1e-6 a random node perturbation does not grow over 500 steps;
//   - the same at 1.25 times the measured limit grows (the probe's limit is real, not a loose bound).
// The table goes to stability_probe.md in the validation output folder (figures_dir(); docs/figures holds the copy
// docs/validation.md quotes).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "host/physics/stability_probe.hpp"
#include "support/capsule_runs.hpp"

namespace capsflow::test {
namespace {

constexpr double kBox = 6.0;  // H = Lx = Lz: room for a pair and a wall gap, small grid (alpha 4: cutoff 0.875)

RunSpec base_spec(const std::string& flow, std::vector<std::pair<std::string, double>> species,
                  std::vector<CapsuleSpecT> caps) {
  RunSpec r;
  r.H = r.Lx = r.Lz = kBox;
  r.alpha = 4.0;  // the seed's split; the smallest box the cutoff allows
  r.flow = flow;
  r.inflation = 0.1;  // the study's prestress (stiffer than a stress-free sphere)
  r.species = std::move(species);
  r.capsules = std::move(caps);
  r.end = 1000.0;
  r.cfl = load_config(preset_path("set_a")).time.cfl;  // the presets' step, the one the study runs at
  return r;
}

Config config_of(const RunSpec& r) { return parse_config(to_toml_text(r), "<stability probe>"); }

// Moves capsule `k` rigidly by d (3 values) in the interleaved position vector x.
void shift_capsule(std::vector<double>& x, int nv, int k, const double* d) {
  for (int i = 0; i < nv; ++i)
    for (int c = 0; c < 3; ++c) x[3 * (static_cast<std::size_t>(k) * nv + i) + c] += d[c];
}

// Capsule 1 moved along direction e until its gap to capsule 0 is `gap` (secant steps on the measured gap).
SimulationSnapshot pair_at_gap(const Config& cfg, const std::vector<double>& start, const double* e, double gap) {
  Simulation sim(cfg);
  const int nv = sim.state().nodes_per_capsule();
  std::vector<double> x = start;
  for (int it = 0; it < 8; ++it) {
    sim.set_positions(x);
    const double g = sim.closing_limits().pair_gap;
    if (!std::isfinite(g)) throw std::runtime_error("pair_at_gap: the pair is farther apart than h_e");
    if (std::abs(g - gap) < 1e-6) break;
    const double d[3] = {(gap - g) * e[0], (gap - g) * e[1], (gap - g) * e[2]};
    shift_capsule(x, nv, 1, d);
  }
  sim.set_positions(x);
  return sim.snapshot();
}

struct Row {
  std::string name;
  double pair_gap = 0, wall_gap = 0;
  StabilityEstimate e;
  double cfl_chosen = 0;
  GrowthResult chosen, over;
};

std::vector<Row>& table() {
  static std::vector<Row> rows;
  return rows;
}

void write_table() {
  std::ostringstream o;
  o << "| configuration | gap | lambda_max (1/strain) | Ritz residual | c = lambda Ca h | cfl_crit (AB2) | chosen cfl "
       "| chosen / crit | growth, 500 steps at chosen | growth at 1.25 crit (steps) |\n";
  o << "|---|---|---|---|---|---|---|---|---|---|\n";
  char buf[512];
  for (const Row& r : table()) {
    const double g = std::isfinite(r.pair_gap) ? r.pair_gap : r.wall_gap;
    std::snprintf(buf, sizeof buf,
                  "| %s | %s | %.4g %+.3gi | %.2g | %.4g | %.4g | %.4g | %.3f | %.3g | %.3g (%d) |\n",
                  r.name.c_str(), std::isfinite(g) ? (std::to_string(g).substr(0, 6)).c_str() : "-", r.e.lambda_re,
                  r.e.lambda_im, r.e.ritz_residual, r.e.c, r.e.cfl_crit, r.cfl_chosen, r.cfl_chosen / r.e.cfl_crit,
                  r.chosen.growth, r.over.growth, r.over.steps);
    o << buf;
  }
  write_figure_file("stability_probe.md", o.str());
}

// Probes the state `snap` and runs the two confirmations; records a row and checks the criteria.
void probe_case(const std::string& name, const Config& cfg, const SimulationSnapshot& snap) {
  Row row;
  row.name = name;
  Simulation sim(cfg, snap, name + ": ");
  sim.evaluate();
  const ClosingLimits cl = sim.closing_limits();
  row.pair_gap = cl.pair_gap;
  row.wall_gap = cl.wall_gap;
  const bool near = cl.pair_gap < sim.near_contact_range();
  row.e = probe_stability(sim, {});
  row.cfl_chosen = cfg.time.cfl * (near ? cfg.time.near_contact_factor : 1.0);
  const double unit = row.e.ca * row.e.h;  // dt = cfl * unit
  {
    Simulation ref(cfg, snap, name + ": "), per(cfg, snap, name + ": ");
    row.chosen = perturbation_growth(ref, per, row.cfl_chosen * unit, 500, 1e-6, 7, 1e6);
  }
  {
    Simulation ref(cfg, snap, name + ": "), per(cfg, snap, name + ": ");
    row.over = perturbation_growth(ref, per, 1.25 * row.e.cfl_crit * unit, 500, 1e-6, 7, 1e3);
  }
  std::printf("%-34s gap %-8.4g lambda %.4g%+.3gi (res %.2g)  c %.4g  cfl_crit %.4g  chosen %.3g  growth %.3g / "
              "%.3g after %d steps at 1.25 crit\n",
              name.c_str(), std::isfinite(cl.pair_gap) ? cl.pair_gap : cl.wall_gap, row.e.lambda_re, row.e.lambda_im,
              row.e.ritz_residual, row.e.c, row.e.cfl_crit, row.cfl_chosen, row.chosen.growth, row.over.growth,
              row.over.steps);
  std::fflush(stdout);
  table().push_back(row);
  write_table();
  EXPECT_LE(row.cfl_chosen, 0.8 * row.e.cfl_crit) << name;
  EXPECT_LE(row.chosen.growth, 1.0) << name;
  EXPECT_FALSE(row.chosen.blew_up) << name;
  EXPECT_GT(row.over.growth, 1.0) << name;
}

const double kC = kBox / 2;

TEST(StabilityProbe, SingleCapsuleAtRest) {
  const Config cfg = config_of(base_spec("none", {{"a", 0.2}}, {{"a", kC, kC, kC}}));
  probe_case("one capsule at rest, Ca 0.2", cfg, Simulation(cfg).snapshot());
}

// A capsule sheared to its steady deformation (6 strain units) at Ca 0.1, 0.2, 0.5.
SimulationSnapshot sheared_single(double ca, Config& cfg) {
  cfg = config_of(base_spec("shear", {{"a", ca}}, {{"a", kC, kC, kC}}));
  Simulation sim(cfg);
  while (sim.time() < 6.0) {
    const StepInfo info = sim.advance();
    if (info.stop != StopReason::None) throw std::runtime_error(info.message);
  }
  return sim.snapshot();
}

TEST(StabilityProbe, SingleCapsuleSheared) {
  for (double ca : {0.1, 0.2, 0.5}) {
    Config cfg;
    const SimulationSnapshot snap = sheared_single(ca, cfg);
    probe_case("one capsule sheared, Ca " + std::to_string(ca).substr(0, 3), cfg, snap);
  }
}

TEST(StabilityProbe, PairAtRest) {
  const Config cfg = config_of(base_spec("none", {{"a", 0.2}}, {{"a", kC - 1.5, kC, kC}, {"a", kC + 1.5, kC, kC}}));
  const std::vector<double> start = Simulation(cfg).positions();
  const double ex[3] = {1.0, 0.0, 0.0};
  std::vector<double> x = start;
  const double in[3] = {-0.9, 0.0, 0.0};  // from 1 a apart to within h_e, then to the gap
  shift_capsule(x, Simulation(cfg).state().nodes_per_capsule(), 1, in);
  for (double gap : {0.02, 0.05, 0.1})
    probe_case("pair at rest, Ca 0.2", cfg, pair_at_gap(cfg, x, ex, gap));
}

TEST(StabilityProbe, PairSheared) {
  // Two copies of the steady sheared capsule (Ca 0.2), one above the other: the configuration of a collision.
  Config one;
  const SimulationSnapshot single = sheared_single(0.2, one);
  const Config cfg =
      config_of(base_spec("shear", {{"a", 0.2}}, {{"a", kC, kC - 1.3, kC}, {"a", kC, kC + 1.3, kC}}));
  Simulation pair(cfg);
  const int nv = pair.state().nodes_per_capsule();
  // The second copy right above the first: centres apart by the shape's y extent plus 0.05 (within h_e), then
  // pair_at_gap sets the gap.
  double ymin = 1e300, ymax = -1e300;
  for (int i = 1; i < 3 * nv; i += 3) {
    ymin = std::min(ymin, single.positions[i]);
    ymax = std::max(ymax, single.positions[i]);
  }
  const double lift = ymax - ymin + 0.05, mid = 0.5 * (ymin + ymax);
  std::vector<double> x(2 * 3 * static_cast<std::size_t>(nv));
  for (int k = 0; k < 2; ++k)
    for (int i = 0; i < 3 * nv; ++i)
      x[3 * static_cast<std::size_t>(k) * nv + i] =
          single.positions[i] + (i % 3 == 1 ? kC - mid + (k == 0 ? -0.5 : 0.5) * lift : 0.0);
  const double ey[3] = {0.0, 1.0, 0.0};
  for (double gap : {0.02, 0.05, 0.1})
    probe_case("pair sheared, Ca 0.2", cfg, pair_at_gap(cfg, x, ey, gap));
}

TEST(StabilityProbe, CapsuleNearWall) {
  const Config cfg = config_of(base_spec("none", {{"a", 0.2}}, {{"a", kC, 1.5, kC}}));
  Simulation sim(cfg);
  std::vector<double> x = sim.positions();
  double ymin = 1e300;
  for (std::size_t i = 1; i < x.size(); i += 3) ymin = std::min(ymin, x[i]);
  for (std::size_t i = 1; i < x.size(); i += 3) x[i] += 0.02 - ymin;
  sim.set_positions(x);
  probe_case("capsule at a wall, at rest, Ca 0.2", cfg, sim.snapshot());
}

// A viscosity ratio (issue 22): the interface equation ((1 + lambda)/2) u - (1 - lambda) K[u] = u_inf + S[f] moves a
// grid-scale mode at 2/(1 + lambda) of its lambda = 1 rate (the double layer of a locally flat surface vanishes), so
// the rule scales Ca by (1 + lambda)/2 (docs/method.md 3.1). A prestressed capsule at rest, lambda 0.2, 1 and 5: the
// measured rate against 2/(1 + lambda) times lambda 1's, and the rule's step against the measured limit as above.
// GMRES to 1e-12 here: the probe's finite differences move the nodes by 1e-7 a, and the growth runs follow a 1e-6 a
// perturbation, both far below the default tolerance's error in the velocity.
double probe_viscosity_ratio(double lambda) {
  RunSpec r = base_spec("none", {{"a", 0.2}}, {{"a", kC, kC, kC}});
  r.species_keys = {"viscosity_ratio = " + std::to_string(lambda) + "\n"};
  Config cfg = config_of(r);
  cfg.gmres.tolerance = 1e-12;
  cfg.gmres.max_iterations = 400;
  probe_case("one capsule at rest, Ca 0.2, lambda " + std::to_string(lambda).substr(0, 3), cfg,
             Simulation(cfg).snapshot());
  return table().back().e.lambda_abs;
}

void check_rate_ratio(double lambda) {
  const double rate = probe_viscosity_ratio(lambda), rate1 = probe_viscosity_ratio(1.0);
  std::printf("  lambda %.1f: rate / lambda-1 rate %.3f, 2/(1 + lambda) %.3f\n", lambda, rate / rate1,
              2.0 / (1.0 + lambda));
  EXPECT_NEAR(rate / rate1 * 0.5 * (1.0 + lambda), 1.0, 0.15) << lambda;
}

TEST(StabilityProbe, ViscosityRatioBelowOne) { check_rate_ratio(0.2); }
TEST(StabilityProbe, ViscosityRatioAboveOne) { check_rate_ratio(5.0); }

// Bending (issue 23): a mode of wavenumber k relaxes at a rate ~ kappa k^3 / mu, so the explicit step's limit goes as
// mu h^3 / kappa, and at the grid scale the in-plane and bending rates add (the rule combines the limits
// harmonically). A capsule at rest, levels 1 and 2: with the in-plane share small (kb / h^2 large) the measured rate
// is linear in kappa (c_b = lambda h^3 / kappa the same at kb 0.5 and 5), and the rule's step is checked against the
// measured limit as the membrane rows are (chosen <= 0.8 crit, no growth at the chosen step; growth at 1.25 crit on
// level 2, see below), also with both mechanisms comparable (Ca 0.2, kb 0.05).
TEST(StabilityProbe, BendingCapsuleAtRest) {
  std::ostringstream md;
  md << "| level | Ca | bending_modulus | kappa | h | lambda_max (1/strain) | Ritz residual | c_b = lambda h^3 / kappa | "
        "chosen dt / crit | growth, 500 steps at chosen | growth at 1.25 crit (steps) |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|\n";
  struct Case {
    int level;
    double ca, kb;
  };
  double cb[2][2] = {{0, 0}, {0, 0}};  // [level 1, 2][kb 0.5, 5]
  for (const Case& k : {Case{1, 50.0, 0.5}, Case{1, 50.0, 5.0}, Case{2, 50.0, 0.5}, Case{2, 50.0, 5.0},
                        Case{2, 0.2, 0.05}}) {
    RunSpec r = base_spec("none", {{"a", k.ca}}, {{"a", kC, kC, kC}});
    r.level = k.level;
    r.bending = {k.kb};
    const Config cfg = config_of(r);
    Simulation sim(cfg);
    sim.evaluate();
    const StabilityEstimate e = probe_stability(sim, {});
    const double kappa = sim.state().bending_rigidity()[0], h = e.h, h3 = h * h * h;
    const double tau_crit = e.cfl_crit * e.ca * h;  // strain units
    const double c = e.lambda_abs * h3 / kappa;
    if (k.ca == 50.0) cb[k.level - 1][k.kb == 5.0 ? 1 : 0] = c;
    const double dt = sim.step_rule().with_bending(cfg.time.cfl * e.ca * h, h);
    GrowthResult chosen, over;
    const SimulationSnapshot snap = sim.snapshot();
    {
      Simulation ref(cfg, snap, "bending: "), per(cfg, snap, "bending: ");
      chosen = perturbation_growth(ref, per, dt, 500, 1e-6, 7, 1e6);
    }
    {
      Simulation ref(cfg, snap, "bending: "), per(cfg, snap, "bending: ");
      over = perturbation_growth(ref, per, 1.25 * tau_crit, 500, 1e-6, 7, 1e3);
    }
    char buf[512];
    std::snprintf(buf, sizeof buf, "| %d | %g | %g | %.4g | %.4g | %.4g %+.3gi | %.2g | %.4g | %.3f | %.3g | %.3g (%d) |\n",
                  k.level, k.ca, k.kb, kappa, h, e.lambda_re, e.lambda_im, e.ritz_residual, c, dt / tau_crit,
                  chosen.growth, over.growth, over.steps);
    std::printf("%s", buf);
    std::fflush(stdout);
    md << buf;
    const std::string name = "level " + std::to_string(k.level) + ", Ca " + std::to_string(k.ca) + ", kb " +
                             std::to_string(k.kb);
    EXPECT_LE(dt, 0.8 * tau_crit) << name;
    EXPECT_LE(chosen.growth, 1.0) << name;
    EXPECT_FALSE(chosen.blew_up) << name;
    // That the probe's limit is real (growth past it) holds where the bending mode dominates on level 2; on level 1
    // and with comparable in-plane and bending rates (Ca 0.2, kb 0.05) a perturbation did not grow at 1.25 times the
    // probe's limit over 500 steps (measured 0.11-0.15 and 0.023): there the probe is conservative, which makes the
    // rule safer, not less safe. Recorded in the table, asserted only where it holds (docs/method.md 4.1).
    if (k.level == 2 && k.ca == 50.0) {
      EXPECT_GT(over.growth, 1.0) << name;
    }
  }
  for (int l = 0; l < 2; ++l) {
    EXPECT_NEAR(cb[l][1] / cb[l][0], 1.0, 0.1) << "the rate is linear in kappa, level " << l + 1;
  }
  write_figure_file("stability_probe_bending.md", md.str());
}

}  // namespace
}  // namespace capsflow::test
