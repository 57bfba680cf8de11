// Long-run fidelity validations of issue 8 (label 'validation': ctest --preset validation). Each test runs
// `capsflow run`'s driver (run_simulation) on a configuration written here, reads the output back with
// read_run_file, prints its numbers and writes a table (.txt) and an SVG figure to the validation output folder
// (support/capsule_runs.hpp figures_dir(): the build tree, never docs/figures; docs/validation.md section 8 records
// the results and commands).
//
// Run one at a time with OMP_NUM_THREADS=2 (ctest --preset validation -R Fidelity).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "host/physics/config.hpp"
#include "host/run/embedded_demo.hpp"
#include "host/run/run_driver.hpp"
#include "host/run/run_layout.hpp"
#include "support/capsule_runs.hpp"
#include "support/temp_dir.hpp"

namespace {

using namespace capsflow;
namespace fs = std::filesystem;

std::string fmt(const char* f, double v) {
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

RunFile run_config(const Config& c, const fs::path& out, RunResult* result = nullptr) {
  RunSettings s;
  s.output = out.string();
  s.quiet = true;
  const RunResult r = run_simulation(c, s, std::cerr);
  if (result) *result = r;
  EXPECT_TRUE(r.exit_code == 0) << r.stop_message;
  return read_run_file(out);
}

RunFile run_text(const std::string& toml, const fs::path& out, RunResult* result = nullptr) {
  return run_config(parse_config(toml, "<validation>"), out, result);
}

// The isolated-capsule preset (examples/presets/isolated.toml: set A box, one pinned capsule, Poiseuille, stopped at
// steady state) at height y0 with capillary number ca; outputs every 0.1, no frames or checkpoints on the way.
Config pinned_set_a(double ca, double y0, std::vector<std::string> extra = {}) {
  const double L = 10.155;
  char center[96];
  std::snprintf(center, sizeof center, "capsule.1.center=[%.17g, %.17g, %.17g]", L / 2, y0, L / 2);
  std::vector<std::string> o = {center, "species.1.ca=" + fmt("%.17g", ca), "output.frames_every=100",
                                "output.checkpoint_every=100"};
  o.insert(o.end(), extra.begin(), extra.end());
  return load_config(test::preset_path("isolated"), parse_overrides(o));
}

// Item "isolated migration to steady state": V^S(y) of isolated Ca 0.2 and 0.5 capsules in the set A box
// (docs/analysis.md §10; KG Fig. 8a S*, F*).
TEST(ValidationFidelity, IsolatedMigrationVelocity) {
  test::TempDir dir;
  const double L = 10.155;
  const std::vector<double> heights = {0.125, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.45, 0.5};
  const std::vector<double> cas = {0.2, 0.5};
  std::ostringstream txt;
  const Config preset = pinned_set_a(0.2, 0.25 * L);
  txt << "# isolated pinned capsule (examples/presets/isolated.toml), set A box (H = Lx = Lz = 10.155), Poiseuille, "
         "level 2, beta 0.1, alpha "
      << preset.ggem.alpha << ", alpha_hm " << preset.ggem.alpha_hm
      << "\n# Ca y0/H V^S (mean U_y over the last strain unit, gammadot_w a) D strain_reached steady\n";
  std::vector<PlotSeries> plot;
  std::vector<std::vector<double>> V(cas.size());
  const char* colors[] = {"#1f77b4", "#d62728"};
  for (std::size_t c = 0; c < cas.size(); ++c) {
    PlotSeries ps;
    ps.label = "isolated, Ca " + fmt("%.1f", cas[c]) + (c == 0 ? " (S*)" : " (F*)");
    ps.color = colors[c];
    for (double h : heights) {
      RunResult r;
      const RunFile f = run_config(pinned_set_a(cas[c], h * L), dir.path / "p.h5", &r);
      fs::remove(dir.path / "p.h5");
      fs::remove(dir.path / "p.checkpoint.h5");
      fs::remove(dir.path / "p.xdmf");
      const bool steady = r.stop_message.find("steady state") != std::string::npos;
      double v = 0.0, D = 0.0;
      int n = 0;
      for (std::size_t t = 0; t < f.records; ++t)
        if (f.time[t] >= f.time.back() - 1.0) {
          v += f.velocity[3 * t + 1];
          D += f.taylor_D[t];
          ++n;
        }
      v /= n;
      D /= n;
      V[c].push_back(v);
      txt << cas[c] << " " << h << " " << fmt("%.6e", v) << " " << fmt("%.5f", D) << " " << f.time.back() << " "
          << (steady ? "yes" : "no") << "\n";
      std::cout << "Ca " << cas[c] << " y0/H " << h << ": V^S " << v << ", D " << D << ", strain " << f.time.back()
                << (steady ? " (steady)" : " (limit reached)") << std::endl;
      EXPECT_TRUE(steady) << "Ca " << cas[c] << " y0/H " << h << ": " << r.stop_message;
      ps.x.push_back(h);
      ps.y.push_back(v);
    }
    plot.push_back(ps);
  }
  test::write_figure_file("migration_isolated.txt", txt.str());
  test::write_figure_file("migration_isolated.svg",
                          svg_line_plot("Isolated pinned capsule in the set A box: V^S(y)", "y / H",
                                        "V^S / (gammadot_w a)", plot));
  for (std::size_t c = 0; c < cas.size(); ++c) {
    for (std::size_t i = 0; i + 1 < heights.size(); ++i) EXPECT_GT(V[c][i], 0.0) << "toward the centreline";
    EXPECT_LT(std::abs(V[c].back()), 1e-5) << "no migration on the centreline";
  }
  // KG: "the single particle migration velocity V^S is larger for the floppy particle".
  for (std::size_t i = 0; i + 1 < heights.size(); ++i) EXPECT_GT(V[1][i], V[0][i]) << "y0/H " << heights[i];
}

// The embedded demo (8 capsules, two species, Poiseuille, H = 8a) run for 100 strain units: with the defaults every
// capsule keeps |V/V0 - 1| <= 1e-4; with the position projection off the velocity projection alone keeps 1e-3.
std::vector<double> worst_volume_drift(const RunFile& f) {
  std::vector<double> worst(f.np, 0.0);
  for (std::size_t t = 0; t < f.records; ++t)
    for (std::size_t k = 0; k < f.np; ++k)
      worst[k] = std::max(worst[k], std::abs(f.volume[t * f.np + k] / f.volume[k] - 1.0));
  return worst;
}

TEST(ValidationFidelity, VolumeHeldOverOneHundredStrain) {
  test::TempDir dir;
  std::ostringstream txt;
  txt << "# embedded demo, 100 strain: worst |V/V0 - 1| per capsule over all records\n";
  for (int position = 1; position >= 0; --position) {
    std::string text = embedded_demo_config();
    text.replace(text.find("end = 40.0"), 10, "end = 100.0");
    if (!position) text.replace(text.find("inflation = 0.1"), 15, "inflation = 0.1\nvolume_correction = false");
    const RunFile f = run_text(text, dir.path / ("v" + std::to_string(position) + ".h5"));
    const std::vector<double> w = worst_volume_drift(f);
    const double worst = *std::max_element(w.begin(), w.end());
    txt << (position ? "defaults (velocity + position projection)" : "velocity projection only") << ": "
        << fmt("%.3e", worst) << " (strain " << f.time.back() << ", " << f.events << " contact events)\n";
    std::cout << txt.str();
    EXPECT_LE(worst, position ? 1e-4 : 1e-3);
  }
  test::write_figure_file("volume_fidelity.txt", txt.str());
}

// A free capsule's centroid follows its recorded (projected, volume-averaged) velocity: the surface moves with the
// velocity the output reports.
TEST(ValidationFidelity, CentroidFollowsTheRecordedVelocity) {
  test::TempDir dir;
  const Config free = pinned_set_a(0.2, 2.0, {"capsule.1.pinned=false", "time.steady_stop=false", "time.end=10"});
  const RunFile f = run_config(free, dir.path / "free.h5");
  double integral = 0.0, worst = 0.0;
  for (std::size_t t = 1; t < f.records; ++t) {
    integral += 0.5 * (f.velocity[3 * t + 1] + f.velocity[3 * (t - 1) + 1]) * (f.time[t] - f.time[t - 1]);
    worst = std::max(worst, std::abs(f.centroid[3 * t + 1] - f.centroid[1] - integral));
  }
  std::cout << "y_c(t) - y_c(0) - int U_y dt: worst " << worst << " over " << f.time.back() << " strain; migrated "
            << f.centroid[3 * (f.records - 1) + 1] - f.centroid[1] << "\n";
  EXPECT_LE(worst, 1e-4);
}

// dt convergence of the D8 rule (issue 8): a pair collision and an 8-capsule Poiseuille segment at cfl 0.5 and 0.25.
TEST(ValidationFidelity, StepConvergencePairCollision) {
  std::ostringstream txt;
  txt << "# pair collision Ca 0.2 (top) | 0.5 (bottom), level 2, beta 0.1, H = 20, Lx = 24, Lz = 12, alpha 1, dx -5 -> +5\n"
      << "# cfl dy_top dy_bottom final_dy steps\n";
  double final_dy[2] = {0, 0};
  const double cfl[2] = {0.5, 0.25};
  for (int i = 0; i < 2; ++i) {
    const test::PairResult p = test::pair_run(0.2, 0.5, 2, 20.0, 24.0, 12.0, 1.0, 2.5, cfl[i]);
    ASSERT_TRUE(p.s.stop.empty()) << p.s.stop;
    final_dy[i] = p.dy_final;
    txt << cfl[i] << " " << fmt("%.5f", p.dy_top) << " " << fmt("%.5f", p.dy_bottom) << " " << fmt("%.5f", p.dy_final)
        << " " << p.s.steps << "\n";
  }
  const double rel = std::abs(final_dy[0] / final_dy[1] - 1.0);
  txt << "# relative difference of the final offset: " << fmt("%.2e", rel) << "\n";
  std::cout << txt.str();
  test::write_figure_file("dt_convergence_pair.txt", txt.str());
  EXPECT_LE(rel, 0.01);
}

TEST(ValidationFidelity, StepConvergenceSuspensionSegment) {
  test::TempDir dir;
  std::ostringstream txt;
  txt << "# embedded demo (8 capsules, H = 8a, Poiseuille) to strain 5: mean |y_c - H/2| per species at the end\n"
      << "# cfl stiff floppy steps\n";
  double m[2][2] = {{0, 0}, {0, 0}}, m0[2] = {0, 0};
  for (int i = 0; i < 2; ++i) {
    std::string text = embedded_demo_config();
    text.replace(text.find("end = 40.0"), 10, i == 0 ? "end = 5.0" : "end = 5.0\ncfl = 0.25");
    RunResult r;
    const RunFile f = run_text(text, dir.path / ("s" + std::to_string(i) + ".h5"), &r);
    const double H = 8.0;
    // The last record is at strain 5 (records every 0.1): compare there.
    const std::size_t t = f.records - 1;
    for (int sp = 0; sp < 2; ++sp) {
      int n = 0;
      for (std::size_t k = 0; k < f.np; ++k)
        if (f.species[k] == sp) {
          m[i][sp] += std::abs(f.centroid[(t * f.np + k) * 3 + 1] - H / 2);
          if (i == 0) m0[sp] += std::abs(f.centroid[k * 3 + 1] - H / 2);
          ++n;
        }
      m[i][sp] /= n;
      if (i == 0) m0[sp] /= n;
    }
    txt << (i == 0 ? 0.5 : 0.25) << " " << fmt("%.6f", m[i][0]) << " " << fmt("%.6f", m[i][1]) << " " << r.steps
        << " (t = " << f.time[t] << ")\n";
  }
  for (int sp = 0; sp < 2; ++sp) {
    const double rel = std::abs(m[0][sp] / m[1][sp] - 1.0);
    const double disp = std::abs((m[0][sp] - m0[sp]) / (m[1][sp] - m0[sp]) - 1.0);
    txt << "# species " << sp << ": relative difference " << fmt("%.2e", rel)
        << "; of the displacement since the start " << fmt("%.2e", disp) << "\n";
    EXPECT_LE(rel, 0.01) << "species " << sp;
  }
  std::cout << txt.str();
  test::write_figure_file("dt_convergence_suspension.txt", txt.str());
}

// Mesh check of the collision ordering (issue 8): the homogeneous displacements at Ca 0.2 and 0.5 hold their
// ordering by 6 % at level 2 and reverse at level 1; repeated at level 3.
TEST(ValidationFidelity, PairOrderingOnLevelThree) {
  std::ostringstream txt;
  txt << "# homogeneous pair collisions, level 3 (642 nodes), beta 0.1, H = 20, Lx = 24, Lz = 12, alpha 1, dx -5 -> +5\n"
      << "# Ca dy_top dy_bottom final_dy steps wall_s\n";
  double top[2] = {0, 0};
  const double cas[2] = {0.2, 0.5};
  for (int i = 0; i < 2; ++i) {
    const test::PairResult p = test::pair_run(cas[i], cas[i], 3, 20.0, 24.0, 12.0, 1.0, 2.5);
    ASSERT_TRUE(p.s.stop.empty()) << p.s.stop;
    top[i] = p.dy_top;
    txt << cas[i] << " " << fmt("%.4f", p.dy_top) << " " << fmt("%.4f", p.dy_bottom) << " " << fmt("%.4f", p.dy_final)
        << " " << p.s.steps << " " << fmt("%.0f", p.s.wall_s) << "\n";
  }
  txt << "# ratio dy_top(0.2) / dy_top(0.5) = " << fmt("%.4f", top[0] / top[1]) << " (level 2: 1.06)\n";
  std::cout << txt.str();
  test::write_figure_file("pair_ordering_level3.txt", txt.str());
  EXPECT_GT(top[0], top[1]) << "KG: the stiffer pair is displaced more";
}

}  // namespace
