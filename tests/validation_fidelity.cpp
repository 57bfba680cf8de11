// Long-run fidelity validations of issue 8 (label 'validation': ctest --preset validation). Each test runs
// `capsflow run`'s driver (run_simulation) on a configuration written here, reads the output back with
// read_run_file, prints its numbers and writes a table (.txt) and an SVG figure to docs/figures/
// (docs/validation.md section 8 records the results and commands).
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

#include "host/config.hpp"
#include "host/embedded_demo.hpp"
#include "host/run_driver.hpp"
#include "host/run_layout.hpp"
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

RunFile run_text(const std::string& toml, const fs::path& out, RunResult* result = nullptr) {
  Config c = parse_config(toml, "<validation>");
  RunSettings s;
  s.output = out.string();
  s.quiet = true;
  const RunResult r = run_simulation(c, s, std::cerr);
  if (result) *result = r;
  EXPECT_TRUE(r.exit_code == 0) << r.stop_message;
  return read_run_file(out);
}

// The set A box (analysis-spec 1.4) with one pinned capsule at height y0, Poiseuille flow, stopped at steady state.
std::string pinned_set_a(double ca, double y0) {
  const double L = 10.155;
  std::ostringstream o;
  o.precision(17);
  o << "[domain]\nH = " << L << "\nLx = " << L << "\nLz = " << L << "\n[ggem]\nalpha = 4.0\nalpha_hm = 0.5\n"
    << "[run]\nbackend = \"threads\"\n[flow]\ntype = \"poiseuille\"\n[capsules]\nmesh_level = 2\ninflation = 0.1\n"
    << "[[species]]\nname = \"s\"\nca = " << ca << "\n[[capsule]]\nspecies = \"s\"\ncenter = [" << L / 2 << ", "
    << y0 << ", " << L / 2 << "]\npinned = true\n"
    << "[time]\nend = 30.0\nsteady_stop = true\nsteady_rtol = 1e-4\nsteady_atol = 1e-7\nsteady_window = 2.0\n"
    << "[output]\nevery = 0.1\nframes_every = 100.0\ncheckpoint_every = 100.0\n";
  return o.str();
}

// Item "isolated migration to steady state": V^S(y) of isolated Ca 0.2 and 0.5 capsules in the set A box
// (analysis-spec 4.6; KG Fig. 8a S*, F*).
TEST(ValidationFidelity, IsolatedMigrationVelocity) {
  test::TempDir dir;
  const double L = 10.155;
  const std::vector<double> heights = {0.125, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.45, 0.5};
  const std::vector<double> cas = {0.2, 0.5};
  std::ostringstream txt;
  txt << "# isolated pinned capsule, set A box (H = Lx = Lz = 10.155), Poiseuille, level 2, beta 0.1, alpha 4, "
         "alpha_hm 0.5\n# Ca y0/H V^S (mean U_y over the last strain unit, gammadot_w a) D strain_reached steady\n";
  std::vector<PlotSeries> plot;
  std::vector<std::vector<double>> V(cas.size());
  const char* colors[] = {"#1f77b4", "#d62728"};
  for (std::size_t c = 0; c < cas.size(); ++c) {
    PlotSeries ps;
    ps.label = "isolated, Ca " + fmt("%.1f", cas[c]) + (c == 0 ? " (S*)" : " (F*)");
    ps.color = colors[c];
    for (double h : heights) {
      RunResult r;
      const RunFile f = run_text(pinned_set_a(cas[c], h * L), dir.path / "p.h5", &r);
      fs::remove(dir.path / "p.h5");
      fs::remove(dir.path / "p.checkpoint.h5");
      fs::remove(dir.path / "p.xdmf");
      fs::remove(dir.path / "p.trajectories.svg");
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
  std::string text = pinned_set_a(0.2, 2.0);
  text.replace(text.find("pinned = true"), 13, "pinned = false");
  text.replace(text.find("steady_stop = true"), 18, "steady_stop = false");
  text.replace(text.find("end = 30.0"), 10, "end = 10.0");
  const RunFile f = run_text(text, dir.path / "free.h5");
  double integral = 0.0, worst = 0.0;
  for (std::size_t t = 1; t < f.records; ++t) {
    integral += 0.5 * (f.velocity[3 * t + 1] + f.velocity[3 * (t - 1) + 1]) * (f.time[t] - f.time[t - 1]);
    worst = std::max(worst, std::abs(f.centroid[3 * t + 1] - f.centroid[1] - integral));
  }
  std::cout << "y_c(t) - y_c(0) - int U_y dt: worst " << worst << " over " << f.time.back() << " strain; migrated "
            << f.centroid[3 * (f.records - 1) + 1] - f.centroid[1] << "\n";
  EXPECT_LE(worst, 1e-4);
}

}  // namespace
