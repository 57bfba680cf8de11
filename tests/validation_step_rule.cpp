// The membrane step rule against the paper's (label 'validation'; docs/validation.md section 9): pair collisions
// (T2 of the step-rule issue) and a short segment of a developed suspension (T3). The tables go to
// step_rule_pairs.txt and step_rule_segment.txt in the validation output folder (figures_dir(); docs/figures holds
// the copies docs/validation.md quotes).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "host/run/checkpoint.hpp"
#include "support/capsule_runs.hpp"

namespace capsflow::test {
namespace {

std::string fmt(const char* f, double v) {
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

// T2: KG's pair collision (H = 20, Lx = 24, Lz = 12, alpha 1, level 2, beta 0.1, dx -5 -> +5) under both rules.
// dy_i = 0.5 reproduces docs/validation.md section 5 (final offset within 1e-3); dy_i = 0.1 and 0.2 bring the pair
// closest (final offset and each displacement within 1 % or 0.005 a).
TEST(StepRulePairs, CollisionsAgreeBetweenTheRules) {
  struct Case {
    double ca_top, ca_bottom, dy;
  };
  const std::vector<Case> cases = {{0.2, 0.2, 0.5}, {0.5, 0.5, 0.5}, {0.2, 0.5, 0.5}, {0.2, 0.2, 0.1},
                                   {0.2, 0.5, 0.1}, {0.2, 0.2, 0.2}, {0.2, 0.5, 0.2}};
  std::ostringstream txt;
  txt << "# pair collisions in simple shear under both step rules: level 2, beta 0.1, H = 20, Lx = 24, Lz = 12, "
         "alpha 1, dx -5 -> +5\n"
      << "# Ca_top Ca_bottom dy_i | rule: dy_top dy_bottom final_dy steps min_gap | rel. diff of final_dy\n";
  for (const Case& c : cases) {
    const PairResult p = pair_run(c.ca_top, c.ca_bottom, 2, 20.0, 24.0, 12.0, 1.0, 2.5, 0.5, "paper", c.dy);
    const PairResult m = pair_run(c.ca_top, c.ca_bottom, 2, 20.0, 24.0, 12.0, 1.0, 2.5, 0.5, "membrane", c.dy);
    ASSERT_TRUE(p.s.stop.empty()) << p.s.stop;
    ASSERT_TRUE(m.s.stop.empty()) << m.s.stop;
    const double rel = std::abs(m.dy_final / p.dy_final - 1.0);
    txt << c.ca_top << " " << c.ca_bottom << " " << c.dy << " | paper: " << fmt("%.5f", p.dy_top) << " "
        << fmt("%.5f", p.dy_bottom) << " " << fmt("%.5f", p.dy_final) << " " << p.s.steps << " "
        << fmt("%.4f", p.s.min_pair_gap) << " | membrane: " << fmt("%.5f", m.dy_top) << " "
        << fmt("%.5f", m.dy_bottom) << " " << fmt("%.5f", m.dy_final) << " " << m.s.steps << " "
        << fmt("%.4f", m.s.min_pair_gap) << " | " << fmt("%.2e", rel) << "\n";
    std::printf("%s", txt.str().substr(txt.str().rfind('\n', txt.str().size() - 2) + 1).c_str());
    std::fflush(stdout);
    if (c.dy == 0.5) {
      EXPECT_LE(rel, 1e-3) << c.ca_top << "|" << c.ca_bottom;
    } else {
      auto close = [](double a, double b) { return std::abs(a - b) <= std::max(0.01 * std::abs(b), 0.005); };
      EXPECT_TRUE(close(m.dy_final, p.dy_final)) << c.ca_top << "|" << c.ca_bottom << " dy " << c.dy;
      EXPECT_TRUE(close(m.dy_top, p.dy_top)) << c.ca_top << "|" << c.ca_bottom << " dy " << c.dy;
      EXPECT_TRUE(close(m.dy_bottom, p.dy_bottom)) << c.ca_top << "|" << c.ca_bottom << " dy " << c.dy;
    }
  }
  write_figure_file("step_rule_pairs.txt", txt.str());
}

// T3: from set C (X_f 0.5, seed 1) developed to strain 40 under the membrane rule at the preset's cfl (0.6 since issue
// 34: the state the study's runs are in), 2 strain units under the paper rule at cfl 0.5 and 0.25 and under the
// membrane rule at the preset's cfl and at 0.5. Asserted: the membrane rule's difference from the paper rule is at
// most 1e-3 of the capsules' cross-stream motion over the segment (5.2e-4 measured 2026-12-07: 1.89e-5 a of 3.6e-2 a,
// docs/validation.md 9.8; a difference that size is far below the statistics' standard errors, T4), and the
// preset's cfl adds at most 1.5x to it against 0.5. Reported, not asserted: the difference over the paper rule's own
// step error (0.5 against 0.25), 0.85 from a state developed at 0.5 and 10.2 from one developed at 0.6, where the
// paper rule's own error is 5x smaller: a ratio to a number that small says nothing of the physics, so the test no
// longer develops at 0.5 to keep it under 3.
TEST(StepRuleSegment, DevelopedSuspensionDiffersByLessThanAThousandthOfTheCrossStreamMotion) {
  // At the split's defaults, as T3 always ran (the presets ask for [ggem] tolerance 1e-2 since issue 34; the rules
  // are compared under one split either way, and the recorded ratios are the defaults').
  Config cfg = load_config(preset_path("set_c"),
                           parse_overrides({"time.end=1000", "output.frames_every=100", "ggem.tolerance=0"}));
  cfg.time.step_rule = StepRule::Membrane;
  SimulationSnapshot snap;
  if (const char* ck = std::getenv("CAPSFLOW_T3_CHECKPOINT"); ck && *ck) {
    // A checkpoint of this very run (set C, X_f 0.5, seed 1, membrane rule) at strain >= 40 saves the development
    // (~1800 steps): the statistics runs of docs/validation.md 9.4 leave one.
    const Checkpoint c = read_checkpoint(ck);
    const Config stored = checkpoint_config(c, ck);
    ASSERT_EQ(stored.suspension->seed, cfg.suspension->seed);
    ASSERT_EQ(stored.suspension->fractions, cfg.suspension->fractions);
    ASSERT_EQ(stored.time.step_rule, StepRule::Membrane);
    ASSERT_EQ(stored.time.cfl, cfg.time.cfl);  // developed at the preset's cfl, as the branch below develops it
    ASSERT_EQ(stored.ggem.tolerance, 0.0);
    ASSERT_EQ(stored.ggem.alpha_hm, cfg.ggem.alpha_hm);
    ASSERT_GE(c.state.time, 40.0);
    snap = c.state;
  } else {
    // Developed at the preset's cfl: the state the study's runs are in.
    Simulation dev(cfg);
    while (dev.time() < 40.0) {
      const StepInfo info = dev.advance();
      ASSERT_EQ(info.stop, StopReason::None) << info.message;
    }
    snap = dev.snapshot();
  }
  const double t_end = snap.time + 2.0;
  // Each branch's centroids at strain t_end exactly, interpolated linearly between the two steps around it (the
  // centroids move at ~1.5 a per strain: comparing at the first step past 42 would measure the step, not the rule).
  auto branch = [&](StepRule rule, double cfl, long* steps) {
    Config c = cfg;
    c.time.step_rule = rule;
    c.time.cfl = cfl;
    Simulation sim(c, snap, "T3: ");
    *steps = 0;
    std::vector<double> before = sim.unwrapped_centroids(sim.geometry());
    double t_before = sim.time();
    while (sim.time() < t_end) {
      before = sim.unwrapped_centroids(sim.geometry());
      t_before = sim.time();
      const StepInfo info = sim.advance();
      if (info.stop != StopReason::None) throw std::runtime_error(info.message);
      ++*steps;
    }
    const std::vector<double> after = sim.unwrapped_centroids(sim.geometry());
    const double w = (t_end - t_before) / (sim.time() - t_before);
    std::vector<double> c42(after.size());
    for (std::size_t i = 0; i < after.size(); ++i) c42[i] = (1.0 - w) * before[i] + w * after[i];
    return c42;
  };
  auto rms = [](const std::vector<double>& a, const std::vector<double>& b) {
    double s = 0.0;
    for (std::size_t i = 0; i < a.size(); ++i) s += (a[i] - b[i]) * (a[i] - b[i]);
    return std::sqrt(s / static_cast<double>(a.size() / 3));
  };
  long n05 = 0, n025 = 0, nm = 0;
  const std::vector<double> p05 = branch(StepRule::Paper, 0.5, &n05), p025 = branch(StepRule::Paper, 0.25, &n025),
                            mem = branch(StepRule::Membrane, cfg.time.cfl, &nm);
  const double ref = rms(p05, p025), diff = rms(mem, p05);
  // The capsules' cross-stream (y) motion over the segment, rms over capsules, from the finest branch.
  Simulation at_start(cfg, snap, "T3: ");
  const std::vector<double> start = at_start.unwrapped_centroids(at_start.geometry());
  double cross = 0.0;
  for (std::size_t i = 1; i < start.size(); i += 3) cross += (p025[i] - start[i]) * (p025[i] - start[i]);
  cross = std::sqrt(cross / static_cast<double>(start.size() / 3));
  // The membrane rule at 0.5 from the same state: what the preset's larger cfl adds to the rule's difference.
  long nm05 = 0;
  const double diff05 = cfg.time.cfl != 0.5 ? rms(branch(StepRule::Membrane, 0.5, &nm05), p05) : diff;
  std::ostringstream txt;
  txt << "# set C, X_f 0.5, seed 1: developed to strain 40 (membrane rule, cfl " << fmt("%g", cfg.time.cfl)
      << "), then 2 strain units per branch\n"
      << "# from strain " << fmt("%.4f", snap.time) << " to " << fmt("%.4f", t_end)
      << "; branch steps (centroids compared at the end, interpolated between steps)\n"
      << "paper cfl 0.5 " << n05 << "\n"
      << "paper cfl 0.25 " << n025 << "\n"
      << "membrane cfl " << fmt("%g", cfg.time.cfl) << " " << nm << "\n"
      << "# rms centroid difference: paper(0.5) vs paper(0.25) " << fmt("%.3e", ref) << "; membrane vs paper(0.5) "
      << fmt("%.3e", diff) << "; ratio " << fmt("%.3f", diff / ref) << "\n"
      << "# rms cross-stream motion over the segment " << fmt("%.3e", cross) << "; membrane vs paper(0.5) / it "
      << fmt("%.3e", diff / cross) << "\n";
  if (cfg.time.cfl != 0.5)
    txt << "# membrane cfl 0.5 from the same state: " << nm05 << " steps, vs paper(0.5) " << fmt("%.3e", diff05)
        << "; ratio " << fmt("%.3f", diff05 / ref) << "\n";
  std::printf("%s", txt.str().c_str());
  write_figure_file("step_rule_segment.txt", txt.str());
  EXPECT_LE(diff, 1e-3 * cross);
  // The preset's cfl (0.6) against 0.5 from the same state: AB2's error grows as cfl^2 (1.44x); measured 1.08-1.23x.
  EXPECT_LE(diff, 1.5 * diff05);
}

}  // namespace
}  // namespace capsflow::test
