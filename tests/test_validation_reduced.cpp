// Reduced-size physics validations of issue 4 (default suite): small boxes and coarse meshes so that the whole
// file runs in about 30 s on 2 cores in release (45 s under AddressSanitizer). Each asserts a physical property
// with a tolerance that covers the reduced resolution and the confinement of the small box; the full-size runs are
// tests/validation_physics.cpp and their results are in docs/validation.md (with the references, VD 1-6).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <cstdio>
#include <string>
#include <vector>

#include "host/physics/stability_probe.hpp"
#include "support/capsule_runs.hpp"

namespace {

using namespace capsflow;
using namespace capsflow::test;

// One capsule in a box close to the smallest the cutoff allows (alpha 2: cutoff 1.75, Lx, Lz >= 7.5), coarse
// spectral grid (alpha_hm 1: D changes by 0.2% against alpha_hm 0.5 at level 2).
RunSpec small_box(int level, double ca, double inflation, const std::string& flow, double H = 8.0) {
  RunSpec r;
  r.H = H;
  r.Lx = r.Lz = 8.0;
  r.alpha = 2.0;
  r.alpha_hm = 1.0;
  r.flow = flow;
  r.level = level;
  r.inflation = inflation;
  r.species = {{"a", ca}};
  r.capsules = {{"a", 4.0, H / 2, 4.0}};
  return r;
}

// Item 1 (reduced): level 2, Ca 0.3, beta 0, walls 3a from the capsule. Unbounded reference D = 0.38-0.39
// (docs/validation.md, VD 2); the full run (H = 20) gives 0.3987 at level 2 and 0.3990 at level 3. The
// confinement of this box (2a/H = 0.25) raises D a little; the band allows -5% / +10% around the reference band.
TEST(ReducedValidation, ShearSteadyDeformation) {
  const double end = 5.0;
  const Series s = run_series(small_box(2, 0.3, 0.0, "shear"), end);
  ASSERT_TRUE(s.stop.empty()) << s.stop;
  const double D = window_mean(s, s.D[0], 4.0, end);
  const double slope = window_slope(s, s.D[0], 4.0, end);
  const double incl = window_mean(s, s.incl[0], 4.0, end);
  const double dv = s.vol[0].back() / s.vol[0].front() - 1.0;
  std::printf("level 2, H = 8: D[4,5] = %.4f, dD/dt = %.2e, inclination = %.4f pi, V(5)/V0 - 1 = %.3e\n", D, slope,
              incl / M_PI, dv);
  EXPECT_GT(D, 0.95 * 0.38);
  EXPECT_LT(D, 1.10 * 0.39);
  // Steady: D changes by less than 1% of itself per strain over the last strain unit.
  EXPECT_LT(std::abs(slope), 0.01 * D);
  // Inclination: the full runs (H = 20) give 0.138 pi at level 2 and 0.140 pi at level 3 (docs/validation.md 1): the
  // mesh moves it by 0.002 pi from level 2 to 3 (0.005 pi at Ca 0.15), the box's confinement by about 0.001 pi. The
  // band, 0.01 pi (1.8 deg) about the level-3 value, is five times the level 2-3 change: a capsule that tilts like
  // another Ca (0.17 pi at 0.15) or not at all (pi/4) falls outside.
  EXPECT_NEAR(incl / M_PI, 0.140, 0.010);
  // Volume loss without pre-inflation (discretisation error, converging with the mesh: 6.2%, 1.9% and 0.35% over
  // 5 strain at levels 1, 2, 3 in the full run): bounded at 3% over 5 strain at level 2.
  EXPECT_LT(std::abs(dv), 0.03);
}

// Item 2 (reduced): D/Ca approaches 25/12 as Ca decreases (level 1).
TEST(ReducedValidation, SmallDeformationLimit) {
  std::vector<double> ratio;
  for (double ca : {0.1, 0.05}) {
    const double end = 2.0;
    const Series s = run_series(small_box(1, ca, 0.0, "shear"), end);
    ASSERT_TRUE(s.stop.empty()) << s.stop;
    ratio.push_back(window_mean(s, s.D[0], 1.5, end) / ca);
  }
  std::printf("level 1: D/Ca = %.4f at Ca 0.1, %.4f at Ca 0.05 (25/12 = 2.0833)\n", ratio[0], ratio[1]);
  const double theory = 25.0 / 12.0;
  EXPECT_LT(ratio[0], ratio[1]);
  EXPECT_NEAR(ratio[1] / theory, 1.0, 0.10) << "D/Ca at Ca 0.05 = " << ratio[1];
}

// Item 3 (reduced): a pre-inflated capsule without flow stays at rest: centroid, volume-averaged velocity and
// shape at round-off level.
TEST(ReducedValidation, InflatedCapsuleAtRest) {
  RunSpec r = small_box(2, 0.2, 0.1, "none");
  r.velocity_projection = r.volume_correction = false;  // the rest state's volume loss is part of what it measures
  r.alpha_hm = 0.5;  // with alpha_hm 1 the coarse grid alone moves the centroid by 5e-6 and gives D ~ 3e-4
  const Series s = run_series(r, 0.5);
  ASSERT_TRUE(s.stop.empty()) << s.stop;
  double disp = 0.0, umax = 0.0;
  for (std::size_t i = 0; i < s.t.size(); ++i) {
    disp = std::max(disp, std::hypot(s.cx[0][i] - s.cx[0][0], s.cy[0][i] - s.cy[0][0], s.cz[0][i] - s.cz[0][0]));
    umax = std::max(umax, std::hypot(s.ux[0][i], s.uy[0][i], s.uz[0][i]));
  }
  EXPECT_LT(disp, 1e-6);
  EXPECT_LT(umax, 1e-6);
  EXPECT_LT(s.D[0].back(), 1e-4);
  // Known discretisation error of the rest state: the nodes drift inward and the volume shrinks (measured 0.9% per
  // time unit at level 2, docs/validation.md); bounded here at 2% per unit so that a regression shows.
  const double change = s.vol[0].back() / s.vol[0].front() - 1.0;
  RecordProperty("volume_change", std::to_string(change));
  EXPECT_LT(std::abs(change), 0.02 * 0.5);
}

// Item 3 (reduced): volume drift of a sheared pre-inflated capsule at the default resolution (level 2, beta 0.1,
// Ca 0.2). Known discretisation error of the rest state (about 1% per strain): measured, bounded at 2% per strain.
TEST(ReducedValidation, VolumeDriftInShear) {
  const double end = 1.0;
  RunSpec r = small_box(2, 0.2, 0.1, "shear");
  r.velocity_projection = r.volume_correction = false;  // the discretisation error itself
  const Series s = run_series(r, end);
  ASSERT_TRUE(s.stop.empty()) << s.stop;
  const double change = s.vol[0].back() / s.vol[0].front() - 1.0;
  RecordProperty("volume_change", std::to_string(change));
  std::printf("sheared, level 2, beta 0.1, Ca 0.2: V(%.1f)/V0 - 1 = %.3e\n", end, change);
  EXPECT_LT(std::abs(change), 0.02 * end);
}

// Item 4 (reduced): Poiseuille flow, H = 10, level 1, Ca 0.3 on the wall shear rate. Pinned: the migration velocity
// points to the centreline at y = H/4 and vanishes there at y = H/2. Free: the capsule moves monotonically toward
// the centreline.
TEST(ReducedValidation, PoiseuilleMigration) {
  // alpha_hm 0.5: with 1.0 the free capsule's wall-normal velocity (~5e-3) fluctuates by ~10% from step to step as
  // it moves across the coarse spectral grid.
  std::vector<double> vm;
  for (double y : {2.5, 5.0}) {
    RunSpec r = small_box(1, 0.3, 0.1, "poiseuille", 10.0);
    r.alpha_hm = 0.5;
    r.capsules = {{"a", 4.0, y, 4.0, true}};
    const Series s = run_series(r, 1.5);
    ASSERT_TRUE(s.stop.empty()) << s.stop;
    vm.push_back(window_mean(s, s.uy[0], 1.0, 1.5));
    EXPECT_NEAR(s.cy[0].back(), y, 1e-9);  // pinned
  }
  EXPECT_GT(vm[0], 0.0);
  EXPECT_LT(std::abs(vm[1]), 0.05 * vm[0]) << "v_m(H/4) = " << vm[0] << ", v_m(H/2) = " << vm[1];

  RunSpec r = small_box(1, 0.3, 0.1, "poiseuille", 10.0);
  r.alpha_hm = 0.5;
  r.capsules = {{"a", 4.0, 2.5, 4.0}};
  const double end = 2.0;
  const Series s = run_series(r, end);
  ASSERT_TRUE(s.stop.empty()) << s.stop;
  // Monotone up to 1e-5 a: while the capsule first deforms, its centroid moves by ~5e-6 a toward the wall.
  for (std::size_t i = 1; i < s.t.size(); ++i) ASSERT_GE(s.cy[0][i], s.cy[0][i - 1] - 1e-5) << "t = " << s.t[i];
  // After the shape transient it moves at roughly the pinned migration velocity.
  EXPECT_GT(s.cy[0].back() - 2.5, 0.25 * vm[0] * end);
  std::printf("v_m(H/4) = %.3e, v_m(H/2) = %.3e, free y(2) - y0 = %.3e\n", vm[0], vm[1], s.cy[0].back() - 2.5);
}

// Item 5 (reduced): pair collisions in shear, H = 8, Lx = 12, Lz = 8 (the paper uses a 30a box and finer meshes). The
// top capsule starts at dx = -2 x_half, dy = +0.5 from the bottom one; the run ends at dx = +2 x_half.
struct Pair {
  double dy_top, dy_bottom, dy_final;
};
Pair pair(double ca_top, double ca_bottom, int level = 1, double x_half = 2.0) {
  RunSpec r;
  r.H = 8.0;
  r.Lx = 12.0;
  r.Lz = 8.0;
  r.alpha = 2.0;
  r.alpha_hm = 1.0;
  r.level = level;
  r.inflation = 0.1;
  r.species = {{"top", ca_top}, {"bottom", ca_bottom}};
  r.capsules = {{"top", 6.0 - x_half, 4.25, 4.0}, {"bottom", 6.0 + x_half, 3.75, 4.0}};
  const Series s = run_series(r, 30.0, 1, [&](const Series& run) {
    return run.cx[0].back() - run.cx[1].back() >= 2 * x_half;
  });
  EXPECT_TRUE(s.stop.empty()) << s.stop;
  EXPECT_GE(s.cx[0].back() - s.cx[1].back(), 2 * x_half) << "the capsules did not pass each other by strain 30";
  return {s.cy[0].back() - s.cy[0].front(), s.cy[1].back() - s.cy[1].front(), s.cy[0].back() - s.cy[1].back()};
}

// Stiff-floppy pair on level 1.
TEST(ReducedValidation, PairCollisionStiffFloppy) {
  const Pair mixed = pair(0.2, 0.5);
  std::printf("stiff-floppy: dy_stiff = %.4f, dy_floppy = %.4f, final dy = %.4f\n", mixed.dy_top, mixed.dy_bottom,
              mixed.dy_final);
  // Irreversible separation: the final cross-stream offset exceeds the initial 0.5.
  EXPECT_GT(mixed.dy_final, 0.5);
  // Heterogeneous pair: the stiff capsule is displaced more than the floppy one.
  EXPECT_GT(mixed.dy_top, 0.0);
  EXPECT_LT(mixed.dy_bottom, 0.0);
  EXPECT_GT(std::abs(mixed.dy_top), std::abs(mixed.dy_bottom));
}

// Homogeneous pairs on level 2 (at level 1 the order is reversed: Ca 0.2 pair 0.31, Ca 0.5 pair 0.44), from dx = -3
// to +3 to keep the cost down (the displacement is taken before the receding side has fully relaxed, so it is larger
// than the full run's: 0.351 and 0.326 here against 0.326 and 0.308).
TEST(ReducedValidation, PairCollisionsStifferPairDisplacedMore) {
  const Pair stiff = pair(0.2, 0.2, 2, 1.5), floppy = pair(0.5, 0.5, 2, 1.5);
  std::printf("level 2 homogeneous pairs: dy_top = %.4f (Ca 0.2), %.4f (Ca 0.5)\n", stiff.dy_top, floppy.dy_top);
  EXPECT_GT(stiff.dy_final, 0.5);
  EXPECT_GT(floppy.dy_final, 0.5);
  EXPECT_GT(stiff.dy_top, floppy.dy_top);
}

// The stability probe's number confirmed by runs (docs/validation.md 9.1, reduced): the capsule of `capsflow probe`'s
// test and of docs/figures/stability_probe.md's first row (level 2, inflation 0.1, Ca 0.2, at rest in the box 6a,
// alpha 4). The probe's limit (cfl_crit 1.024: tests/test_probe_command.cpp holds the command to it) is an Arnoldi
// estimate on a finite-difference Jacobian; here fixed-step runs from a 1e-6 a node perturbation check it from the
// other side: below the limit the perturbation does not grow, above it it grows a hundredfold. And the presets' cfl
// (examples/presets/set_a.toml) is within the criterion of docs/method.md 4.1, at most 0.8 of the limit.
TEST(ReducedValidation, ProbeLimitConfirmedByPerturbationRuns) {
  const Config cfg = parse_config(
      "[domain]\nH = 6.0\nLx = 6.0\nLz = 6.0\n[ggem]\nalpha = 4.0\n[run]\nbackend = \"threads\"\n[flow]\n"
      "type = \"none\"\n[capsules]\nmesh_level = 2\ninflation = 0.1\n[[species]]\nname = \"a\"\nca = 0.2\n"
      "[[capsule]]\nspecies = \"a\"\ncenter = [3.0, 3.0, 3.0]\n[time]\nend = 1000.0\n",
      "<probe case>");
  Simulation probe(cfg);
  probe.evaluate();
  const StabilityEstimate e = probe_stability(probe, {});
  const double unit = e.ca * e.h;  // dt = cfl * unit
  std::printf("probe: lambda %.4g%+.3gi per strain, cfl_crit %.4f\n", e.lambda_re, e.lambda_im, e.cfl_crit);
  EXPECT_NEAR(e.cfl_crit, 1.024, 0.005);
  const auto growth = [&](double cfl) {
    Simulation ref(cfg), per(cfg);
    const GrowthResult g = perturbation_growth(ref, per, cfl * unit, 300, 1e-6, 7, 1e3);
    std::printf("  %.2f x the limit: growth %.3g after %d steps%s\n", cfl / e.cfl_crit, g.growth, g.steps,
                g.blew_up ? " (blew up)" : "");
    return g;
  };
  const GrowthResult below = growth(0.9 * e.cfl_crit), above = growth(1.15 * e.cfl_crit);
  EXPECT_FALSE(below.blew_up);
  EXPECT_LE(below.growth, 1.0) << "0.9 of the probe's limit is unstable: the probe overestimates the limit";
  EXPECT_GT(above.growth, 100.0) << "1.15 of the probe's limit is stable: the probe underestimates the limit";
  const Config preset = load_config(preset_path("set_a"));
  std::printf("  the presets' cfl %.2f = %.3f of the limit (criterion 0.8)\n", preset.time.cfl,
              preset.time.cfl / e.cfl_crit);
  EXPECT_LE(preset.time.cfl, 0.8 * e.cfl_crit);
}

// Validation programs write their tables and figures into the build tree, never over the committed docs/figures
// (which docs/validation.md quotes and which are copied there on purpose).
TEST(ValidationOutput, GoesToTheBuildTreeNotTheCommittedFigures) {
  const char* saved = std::getenv("CAPSFLOW_VALIDATION_OUT");
  const std::string keep = saved != nullptr ? saved : "";
  unsetenv("CAPSFLOW_VALIDATION_OUT");
  const std::string dir = figures_dir();
  if (saved != nullptr) setenv("CAPSFLOW_VALIDATION_OUT", keep.c_str(), 1);
  ASSERT_FALSE(dir.empty());
  namespace fs = std::filesystem;
  const fs::path out = fs::weakly_canonical(dir), docs = fs::weakly_canonical(source_dir() + "/docs");
  EXPECT_EQ(out.filename(), "validation-figures") << out;
  const auto rel = out.lexically_relative(docs);
  EXPECT_TRUE(rel.empty() || *rel.begin() == "..") << out << " lies under " << docs;
}

}  // namespace
