// Full-size physics validations of issue 4 (label 'validation': ctest --preset validation). Each test runs the
// production Simulation, prints its numbers, and writes a number table (.txt) and an SVG figure to the validation
// output folder (figures_dir(): the build tree, never docs/figures; docs/validation.md records the results, commands
// and the references VD 1-6).
//
// Run one at a time with OMP_NUM_THREADS=2; the whole file takes about 8 minutes on 2 idle cores.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "support/capsule_runs.hpp"

namespace {

using namespace capsflow;
using namespace capsflow::test;

constexpr double kPi = 3.14159265358979323846;
const char* kColors[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b"};

std::string fmt(const char* f, double v) {
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

// One capsule at the centre of a 20 x 20 x 20 slit in simple shear, beta = 0 (walls 9a from the surface).
RunSpec single_shear(int level, double ca, double end) {
  RunSpec r;
  r.H = 20.0;
  r.Lx = r.Lz = 20.0;
  r.alpha = 1.0;  // cutoff 3.5: needs Lx, Lz >= 11
  r.alpha_hm = 0.5;
  r.level = level;
  r.inflation = 0.0;
  r.species = {{"a", ca}};
  r.capsules = {{"a", 10.0, 10.0, 10.0}};
  r.end = end;
  return r;
}

// Item 1: steady D at Ca = 0.15 and 0.3 against the unbounded-shear band (docs/validation.md, VD 2), levels 1-3.
void shear_deformation(double ca, double band_lo, double band_hi, const std::string& tag) {
  const double end = 5.0, t0 = 4.0;
  std::vector<double> Dm(4), incl(4), slope(4);
  std::vector<PlotSeries> plot;
  std::ostringstream txt;
  txt << "# one capsule, simple shear, Ca = " << ca << ", beta = 0, H = Lx = Lz = 20, alpha = 1, alpha_hm = 0.5\n"
      << "# level nodes D_mean[4,5] dD/dt[4,5] inclination/pi[4,5] V/V0(end) steps wall_s\n";
  for (int level = 1; level <= 3; ++level) {
    const Series s = run_series(single_shear(level, ca, end), end);
    ASSERT_TRUE(s.stop.empty()) << s.stop;
    Dm[level] = window_mean(s, s.D[0], t0, end);
    slope[level] = window_slope(s, s.D[0], t0, end);
    incl[level] = window_mean(s, s.incl[0], t0, end) / kPi;
    const int nodes = level == 1 ? 42 : level == 2 ? 162 : 642;
    txt << level << " " << nodes << " " << fmt("%.4f", Dm[level]) << " " << fmt("%.2e", slope[level]) << " "
        << fmt("%.4f", incl[level]) << " " << fmt("%.5f", s.vol[0].back() / s.vol[0].front()) << " " << s.steps
        << " " << fmt("%.0f", s.wall_s) << "\n";
    plot.push_back({"level " + std::to_string(level) + " (" + std::to_string(nodes) + " nodes)", s.t, s.D[0],
                    kColors[level - 1]});
  }
  plot.push_back({"reference band low", {0.0, end}, {band_lo, band_lo}, "#000000", true});
  plot.push_back({"reference band high", {0.0, end}, {band_hi, band_hi}, "#000000", true});
  std::printf("%s", txt.str().c_str());
  write_figure_file("shear_D_" + tag + ".txt", txt.str());
  write_figure_file("shear_D_" + tag + ".svg",
                    svg_line_plot("One capsule in simple shear, Ca = " + fmt("%.2f", ca) + ", beta = 0",
                                  "strain", "Taylor D", plot));
  // Steady on the finest mesh: the D drift over the last strain unit is below 1% of D per strain. (Levels 1 and 2
  // still creep upward at strain 4-5, 1.2% per strain at level 2 and Ca 0.15, together with their volume loss of
  // 5-6% and 1.6-1.9% over 5 strain; reported in docs/validation.md, not asserted.)
  EXPECT_LT(std::abs(slope[3]), 0.01 * Dm[3]);
  // Converging: the level 2 -> 3 change is smaller than the level 1 -> 2 change.
  EXPECT_LT(std::abs(Dm[3] - Dm[2]), std::abs(Dm[2] - Dm[1]));
  // Finest mesh within 5% of the reference band.
  EXPECT_GE(Dm[3], 0.95 * band_lo);
  EXPECT_LE(Dm[3], 1.05 * band_hi);
}

TEST(ValidationShear, SteadyDeformationCa015) { shear_deformation(0.15, 0.26, 0.28, "ca015"); }
TEST(ValidationShear, SteadyDeformationCa030) { shear_deformation(0.30, 0.38, 0.39, "ca030"); }

// Item 2: D / Ca -> 25/12 as Ca -> 0 (level 2).
TEST(ValidationShear, SmallDeformationLimit) {
  const std::vector<double> cas = {0.1, 0.05, 0.025};
  const double end = 3.0;
  std::vector<double> ratio;
  std::vector<PlotSeries> plot;
  std::ostringstream txt;
  txt << "# small-deformation limit, level 2, beta = 0, H = Lx = Lz = 20; D averaged over strain [2.5, 3]\n"
      << "# Ca D D/Ca (D/Ca)/(25/12) inclination/pi steps wall_s\n";
  PlotSeries r{"D/Ca, level 2", {}, {}, kColors[0]};
  for (std::size_t i = 0; i < cas.size(); ++i) {
    const Series s = run_series(single_shear(2, cas[i], end), end);
    ASSERT_TRUE(s.stop.empty()) << s.stop;
    const double D = window_mean(s, s.D[0], 2.5, end);
    ratio.push_back(D / cas[i]);
    txt << cas[i] << " " << fmt("%.5f", D) << " " << fmt("%.4f", D / cas[i]) << " "
        << fmt("%.4f", D / cas[i] / (25.0 / 12.0)) << " " << fmt("%.4f", window_mean(s, s.incl[0], 2.5, end) / kPi)
        << " " << s.steps << " " << fmt("%.0f", s.wall_s) << "\n";
    r.x.push_back(cas[i]);
    r.y.push_back(D / cas[i]);
  }
  plot.push_back(r);
  plot.push_back({"25/12 (theory)", {0.0, 0.11}, {25.0 / 12.0, 25.0 / 12.0}, "#000000", true});
  std::printf("%s", txt.str().c_str());
  write_figure_file("small_deformation.txt", txt.str());
  write_figure_file("small_deformation.svg",
                    svg_line_plot("Small-deformation limit: D/Ca vs Ca", "Ca", "D / Ca", plot));
  // D/Ca increases toward 25/12 from Ca 0.1 to 0.05 and is within 5% of it at Ca = 0.025. Between Ca 0.05 and
  // 0.025 level 2 gives 2.063 then 2.054 (-0.5%): the expected rise (~+1%) is below the level-2 error (-1.4% at
  // Ca 0.025 against level 3), so that ordering is asserted on level 3 (SmallDeformationLevel3: 2.072, 2.081).
  EXPECT_LT(ratio[0], ratio[1]);
  EXPECT_NEAR(ratio[2] / (25.0 / 12.0), 1.0, 0.05);
}

// Item 2, check of the level-2 result: D/Ca at Ca 0.05 and 0.025 on the level-3 mesh (shorter runs: the
// relaxation time scales with Ca; D averaged over strain [1, 1.5]).
TEST(ValidationShear, SmallDeformationLevel3) {
  std::ostringstream txt;
  txt << "# small-deformation limit, level 3, beta = 0, H = Lx = Lz = 20; D averaged over strain [1, 1.5]\n"
      << "# Ca D D/Ca (D/Ca)/(25/12) D_mean[0.5,1] steps wall_s\n";
  std::vector<double> ratio;
  for (double ca : {0.05, 0.025}) {
    const double end = 1.5;
    const Series s = run_series(single_shear(3, ca, end), end);
    ASSERT_TRUE(s.stop.empty()) << s.stop;
    const double D = window_mean(s, s.D[0], 1.0, end);
    ratio.push_back(D / ca);
    txt << ca << " " << fmt("%.5f", D) << " " << fmt("%.4f", D / ca) << " " << fmt("%.4f", D / ca / (25.0 / 12.0))
        << " " << fmt("%.5f", window_mean(s, s.D[0], 0.5, 1.0)) << " " << s.steps << " " << fmt("%.0f", s.wall_s)
        << "\n";
  }
  std::printf("%s", txt.str().c_str());
  write_figure_file("small_deformation_level3.txt", txt.str());
  write_figure_file("small_deformation_level3.svg",
                    svg_line_plot("Small-deformation limit on level 3: D/Ca vs Ca", "Ca", "D / Ca",
                                  {{"D/Ca, level 3", {0.05, 0.025}, {ratio[0], ratio[1]}, kColors[2]},
                                   {"25/12 (theory)", {0.0, 0.06}, {25.0 / 12.0, 25.0 / 12.0}, "#000000", true}}));
  EXPECT_LT(ratio[0], ratio[1]);
  EXPECT_NEAR(ratio[1] / (25.0 / 12.0), 1.0, 0.05);
}

// Item 3a: a pre-inflated capsule without flow stays at rest: levels 1-3, inflation 0.1, Ca 0.2. The centroid and
// the volume-averaged velocity stay at round-off level; the nodes move inward (the discrete single layer of a
// uniform isotropic tension is not exactly zero), so the volume shrinks at a rate that is measured per level and
// must fall with refinement.
TEST(ValidationRest, InflatedCapsuleAtRest) {
  std::ostringstream txt;
  txt << "# inflated capsule at rest: inflation 0.1, Ca 0.2, flow none, H = Lx = Lz = 8, alpha 2\n"
      << "# level end max_centroid_disp max_|U| max_node_speed(t=0) dV/V0_per_strain D(end) steps wall_s\n";
  std::vector<double> rate(4);
  std::vector<PlotSeries> plot;
  for (int level = 1; level <= 3; ++level) {
    RunSpec r;
    r.velocity_projection = r.volume_correction = false;  // measures the discretisation's volume loss
    r.H = 8.0;
    r.Lx = r.Lz = 8.0;
    r.alpha = 2.0;
    r.flow = "none";
    r.level = level;
    r.inflation = 0.1;
    r.species = {{"a", 0.2}};
    r.capsules = {{"a", 4.0, 4.0, 4.0}};
    const double end = level == 3 ? 1.0 : 2.0;
    const Series s = run_series(r, end);
    ASSERT_TRUE(s.stop.empty()) << s.stop;
    double disp = 0.0, umax = 0.0;
    std::vector<double> vrel(s.t.size());
    for (std::size_t i = 0; i < s.t.size(); ++i) {
      disp = std::max(disp, std::hypot(s.cx[0][i] - s.cx[0][0], s.cy[0][i] - s.cy[0][0], s.cz[0][i] - s.cz[0][0]));
      umax = std::max(umax, std::hypot(s.ux[0][i], s.uy[0][i], s.uz[0][i]));
      vrel[i] = s.vol[0][i] / s.vol[0][0];
    }
    rate[level] = window_slope(s, vrel, 0.0, end);
    txt << level << " " << end << " " << fmt("%.2e", disp) << " " << fmt("%.2e", umax) << " "
        << fmt("%.3e", s.max_node_speed.front()) << " " << fmt("%.3e", rate[level]) << " "
        << fmt("%.2e", s.D[0].back()) << " " << s.steps << " " << fmt("%.0f", s.wall_s) << "\n";
    plot.push_back({"level " + std::to_string(level), s.t, vrel, kColors[level - 1]});
    EXPECT_LT(disp, 1e-6) << "level " << level;
    EXPECT_LT(umax, 1e-6) << "level " << level;
    EXPECT_LT(s.D[0].back(), 1e-4) << "level " << level;
  }
  std::printf("%s", txt.str().c_str());
  write_figure_file("rest.txt", txt.str());
  write_figure_file("rest_volume.svg", svg_line_plot("Inflated capsule at rest (no flow), beta = 0.1, Ca = 0.2",
                                                     "time (1/gammadot units)", "V / V0", plot));
  // The spurious shrinking is a discretisation error: it must decrease with refinement.
  EXPECT_LT(std::abs(rate[2]), std::abs(rate[1]));
  EXPECT_LT(std::abs(rate[3]), std::abs(rate[2]));
}

// Item 3b: volume drift of a sheared capsule at the default resolution (level 2, inflation 0.1), Ca 0.2, 20 strain.
TEST(ValidationRest, VolumeDriftInShear) {
  RunSpec r;
  r.velocity_projection = r.volume_correction = false;  // the discretisation error itself (issue 8: corrections off)
  r.H = 10.0;
  r.Lx = r.Lz = 10.0;
  r.alpha = 2.0;
  r.level = 2;
  r.inflation = 0.1;
  r.species = {{"a", 0.2}};
  r.capsules = {{"a", 5.0, 5.0, 5.0}};
  const double end = 20.0;
  const Series s = run_series(r, end, 4);
  ASSERT_TRUE(s.stop.empty()) << s.stop;
  std::vector<double> vrel(s.t.size()), arel(s.t.size());
  for (std::size_t i = 0; i < s.t.size(); ++i) {
    vrel[i] = s.vol[0][i] / s.vol[0][0];
    arel[i] = s.area[0][i] / s.area[0][0];
  }
  const double slope = window_slope(s, vrel, 5.0, end);  // per strain, after the initial transient
  std::ostringstream txt;
  txt << "# volume drift: level 2, inflation 0.1, Ca 0.2, simple shear, H = Lx = Lz = 10, alpha 2, to t = " << end
      << "\n"
      << "V(5)/V0 " << fmt("%.5f", value_at(s, vrel, 5.0)) << "\nV(10)/V0 " << fmt("%.5f", value_at(s, vrel, 10.0))
      << "\nV(20)/V0 " << fmt("%.5f", vrel.back()) << "\nslope over [5,20] per strain " << fmt("%.3e", slope)
      << "\nextrapolated change per 100 strain " << fmt("%.3f", 100 * slope) << "\nD mean [10,20] "
      << fmt("%.4f", window_mean(s, s.D[0], 10, end)) << "\nsteps " << s.steps << " wall_s " << fmt("%.0f", s.wall_s)
      << "\n";
  std::printf("%s", txt.str().c_str());
  write_figure_file("volume_drift.txt", txt.str());
  write_figure_file("volume_drift.svg",
                    svg_line_plot("Sheared capsule, level 2, beta = 0.1, Ca = 0.2", "strain", "V/V0, A/A0",
                                  {{"V/V0", s.t, vrel, kColors[0]}, {"A/A0", s.t, arel, kColors[1]}}));
  // Measured and reported; the assertion only bounds it (a drift beyond 1%/strain would be a regression).
  EXPECT_LT(std::abs(slope), 0.01);
}

// Item 4: lateral migration in plane Poiseuille flow (H = 10, Ca 0.3 on the wall shear rate, beta 0.1, level 2).
RunSpec poiseuille(double y, bool pinned) {
  RunSpec r;
  r.H = 10.0;
  r.Lx = r.Lz = 10.0;
  r.alpha = 2.0;
  r.flow = "poiseuille";
  r.level = 2;
  r.inflation = 0.1;
  r.species = {{"a", 0.3}};
  r.capsules = {{"a", 5.0, y, 5.0, pinned}};
  return r;
}

TEST(ValidationMigration, FreeTrajectory) {
  const double end = 40.0, y0 = 2.5;
  const Series s = run_series(poiseuille(y0, false), end, 4);
  ASSERT_TRUE(s.stop.empty()) << s.stop;
  std::vector<double> yH(s.t.size());
  int decreases = 0;
  for (std::size_t i = 0; i < s.t.size(); ++i) {
    yH[i] = s.cy[0][i] / 10.0;
    if (i > 0 && s.cy[0][i] < s.cy[0][i - 1] - 1e-5) ++decreases;  // ~5e-6 dip while the shape develops
  }
  std::ostringstream txt;
  txt << "# free migration in Poiseuille flow: H = 10, Ca 0.3 (wall shear rate), beta 0.1, level 2, y0 = 2.5\n"
      << "# t y/H\n";
  for (double t : {0.0, 5.0, 10.0, 20.0, 30.0, 40.0}) txt << t << " " << fmt("%.4f", value_at(s, yH, t)) << "\n";
  txt << "records with y decreasing: " << decreases << " of " << s.t.size() << "\nsteps " << s.steps << " wall_s "
      << fmt("%.0f", s.wall_s) << "\n";
  std::printf("%s", txt.str().c_str());
  write_figure_file("migration_free.txt", txt.str());
  write_figure_file("migration_free.svg",
                    svg_line_plot("Free capsule in Poiseuille flow, Ca = 0.3, H = 10a", "strain (wall shear rate)",
                                  "y / H", {{"centroid", s.t, yH, kColors[0]},
                                            {"centreline", {0.0, end}, {0.5, 0.5}, "#000000", true}}));
  EXPECT_EQ(decreases, 0);
  EXPECT_GT(yH.back(), yH.front() + 0.02);
  EXPECT_LT(yH.back(), 0.5);
}

TEST(ValidationMigration, PinnedMigrationVelocity) {
  const std::vector<double> ys = {1.75, 2.25, 2.75, 3.25, 3.75, 4.25, 5.0};
  const double end = 3.0;
  std::vector<double> vm;
  std::ostringstream txt;
  txt << "# pinned capsule in Poiseuille flow: H = 10, Ca 0.3 (wall shear rate), beta 0.1, level 2\n"
      << "# v_m = volume-averaged wall-normal velocity averaged over strain [2, 3] (units gammadot_w a)\n"
      << "# y y/H v_m D steps wall_s\n";
  PlotSeries p{"pinned capsule, level 2", {}, {}, kColors[0]};
  for (double y : ys) {
    const Series s = run_series(poiseuille(y, true), end);
    ASSERT_TRUE(s.stop.empty()) << s.stop;
    const double v = window_mean(s, s.uy[0], 2.0, end);
    vm.push_back(v);
    txt << y << " " << fmt("%.3f", y / 10.0) << " " << fmt("%.3e", v) << " "
        << fmt("%.4f", window_mean(s, s.D[0], 2.0, end)) << " " << s.steps << " " << fmt("%.0f", s.wall_s) << "\n";
    p.x.push_back(y / 10.0);
    p.y.push_back(v);
  }
  std::printf("%s", txt.str().c_str());
  write_figure_file("migration_pinned.txt", txt.str());
  write_figure_file("migration_pinned.svg",
                    svg_line_plot("Migration velocity of a pinned capsule, Poiseuille, Ca = 0.3", "y / H",
                                  "v_m / (gammadot_w a)", {p, {"zero", {0.15, 0.5}, {0.0, 0.0}, "#000000", true}}));
  // Toward the centreline below it, growing toward the wall, ~0 at the centreline.
  for (std::size_t i = 0; i + 1 < vm.size(); ++i) {
    EXPECT_GT(vm[i], 0.0) << "y = " << ys[i];
    EXPECT_GT(vm[i], vm[i + 1]) << "y = " << ys[i];
  }
  EXPECT_LT(std::abs(vm.back()), 0.05 * vm.front());
}

// Item 5: pair collisions in simple shear (KG's pair collisions; docs/validation.md, VD 6).
// The top capsule starts at (Lx/2 - 2.5, H/2 + 0.25), the bottom one at (Lx/2 + 2.5, H/2 - 0.25); the run ends
// when their x separation is back to +5 (or at strain 30).
TEST(ValidationPairs, CollisionDisplacements) {
  struct Case {
    const char* name;
    double ca_top, ca_bottom;
  };
  const std::vector<Case> cases = {{"Ca 0.2|0.2", 0.2, 0.2}, {"Ca 0.5|0.5", 0.5, 0.5}, {"Ca 0.2|0.5", 0.2, 0.5}};
  std::ostringstream txt;
  txt << "# pair collisions in simple shear: level 2, beta 0.1, H = 20, Lx = 24, Lz = 12, alpha 1;\n"
      << "# start dx = -5, dy = 0.5 (top above), end when dx = +5\n"
      << "# case (Ca top|bottom) dy_top dy_bottom final_dy(initial 0.5) end_strain steps wall_s\n";
  std::vector<PairResult> res;
  std::vector<PlotSeries> plot;
  for (std::size_t i = 0; i < cases.size(); ++i) {
    PairResult p = pair_run(cases[i].ca_top, cases[i].ca_bottom, 2, 20.0, 24.0, 12.0, 1.0, 2.5);
    ASSERT_TRUE(p.s.stop.empty()) << p.s.stop;
    txt << cases[i].name << " " << fmt("%.4f", p.dy_top) << " " << fmt("%.4f", p.dy_bottom) << " "
        << fmt("%.4f", p.dy_final) << " " << fmt("%.2f", p.s.t.back()) << " " << p.s.steps << " "
        << fmt("%.0f", p.s.wall_s) << "\n";
    std::vector<double> yt(p.s.t.size()), yb(p.s.t.size());
    for (std::size_t k = 0; k < p.s.t.size(); ++k) {
      yt[k] = p.s.cy[0][k] - p.s.cy[0][0];
      yb[k] = -(p.s.cy[1][k] - p.s.cy[1][0]);
    }
    plot.push_back({std::string(cases[i].name) + " top", p.s.t, yt, kColors[i]});
    plot.push_back({std::string(cases[i].name) + " bottom", p.s.t, yb, kColors[i], true});
    res.push_back(std::move(p));
  }
  std::printf("%s", txt.str().c_str());
  write_figure_file("pair_collisions.txt", txt.str());
  write_figure_file("pair_collisions.svg",
                    svg_line_plot("Pair collisions in shear: cross-stream displacement", "strain",
                                  "top: y - y_i (solid); bottom: y_i - y (dashed)", plot));
  for (const auto& p : res) EXPECT_GT(p.dy_final, 0.5);  // irreversible separation
  // Homogeneous: the stiffer pair is displaced more (0.1 <= Ca <= 0.6).
  EXPECT_GT(res[0].dy_top, res[1].dy_top);
  // Heterogeneous: the stiff capsule is displaced more than the floppy one.
  EXPECT_GT(std::abs(res[2].dy_top), std::abs(res[2].dy_bottom));
}

}  // namespace
