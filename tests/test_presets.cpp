// The shipped presets (examples/presets/): each one parses, passes the run checks, and matches the seed's Table I
// (Kumar & Graham: phi, 2a/H, N_p, the Ca pair and R, to the digits the table prints) at every X_f of the study;
// the isolated and pair presets match docs/analysis.md §10 / §12. The memory estimator against a grid counted by
// hand.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "host/physics/config.hpp"
#include "host/physics/initial_conditions.hpp"
#include "host/run/run_estimate.hpp"
#include "kernels/ggem_kernels.hpp"
#include "kernels/mode_solve.hpp"

namespace capsflow {
namespace {

std::string source_dir() {
  if (const char* env = std::getenv("CAPSFLOW_SOURCE_DIR"); env && *env) return env;
#ifdef CAPSFLOW_TEST_DEFAULT_SOURCE_DIR
  return CAPSFLOW_TEST_DEFAULT_SOURCE_DIR;
#else
  return "";
#endif
}

std::string preset(const std::string& name) { return source_dir() + "/examples/presets/" + name + ".toml"; }

// `v` printed with `decimals` digits after the point, as Table I prints its entries.
std::string printed(double v, int decimals) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}
int decimals_of(const std::string& s) {
  const auto dot = s.find('.');
  return dot == std::string::npos ? 0 : static_cast<int>(s.size() - dot - 1);
}

// Table I of the paper (KG, arXiv:1109.6601; docs/analysis.md §2), as printed.
struct TableRow {
  const char* set;
  const char* ca1;  // stiff
  const char* ca2;  // floppy
  const char* R;
  const char* phi;
  const char* two_a_over_H;
  int Np;
};
const TableRow kTableI[] = {
    {"a", "0.2", "0.5", "2.5", "0.2", "0.197", 50},
    {"b", "0.2", "0.5", "2.5", "0.2", "0.3", 50},
    {"c", "0.2", "0.5", "2.5", "0.12", "0.197", 30},
    {"d", "0.1", "0.6", "6.0", "0.12", "0.197", 30},
};
// X_f of the study (docs/analysis.md §2: 0 to 1 in steps of 0.2).
const char* kXf[] = {"0", "0.2", "0.4", "0.6", "0.8", "1"};

TEST(Presets, SetsMatchTableIAtEveryFloppyFraction) {
  if (source_dir().empty()) GTEST_SKIP() << "CAPSFLOW_SOURCE_DIR not set";
  for (const TableRow& row : kTableI) {
    for (const char* xf_text : kXf) {
      SCOPED_TRACE(std::string("set ") + row.set + ", X_f = " + xf_text);
      const double xf = std::stod(xf_text);
      const std::string fr = "suspension.fractions=[" + std::string(printed(1.0 - xf, 1)) + ", " + xf_text + "]";
      const Config c = load_config(preset(std::string("set_") + row.set), parse_overrides({fr}));
      validate_run_config(c);
      ASSERT_EQ(c.species.size(), 2u);
      const double a = c.capsules.radius, H = c.domain.H;
      const long np = suspension_count(c);
      const double phi = static_cast<double>(np) * 4.0 / 3.0 * kPi * a * a * a / (H * c.domain.Lx * c.domain.Lz);
      const double ca1 = c.species[0].ca, ca2 = c.species[1].ca;
      EXPECT_EQ(np, row.Np);
      EXPECT_EQ(printed(phi, decimals_of(row.phi)), row.phi) << phi;
      EXPECT_EQ(printed(2.0 * a / H, decimals_of(row.two_a_over_H)), row.two_a_over_H) << 2.0 * a / H;
      EXPECT_EQ(printed(ca1, decimals_of(row.ca1)), row.ca1);
      EXPECT_EQ(printed(ca2, decimals_of(row.ca2)), row.ca2);
      EXPECT_EQ(printed(ca2 / ca1, decimals_of(row.R)), row.R);
      // Stiff first, and the counts give exactly the fraction X_f (docs/analysis.md §2's table of counts).
      EXPECT_LT(ca1, ca2);
      const std::vector<long> n = species_counts(np, c.suspension->fractions);
      EXPECT_EQ(n[0] + n[1], np);
      EXPECT_EQ(static_cast<double>(n[1]) / static_cast<double>(np) * 5.0, xf * 5.0);  // X_f = k / 5 exactly
      // The study's settings (docs/analysis.md §2; issue 10).
      EXPECT_EQ(c.flow.type, FlowType::Poiseuille);
      EXPECT_EQ(c.capsules.mesh_level, 2);
      EXPECT_EQ(c.capsules.membrane.inflation, 0.1);
      EXPECT_EQ(c.time.min_gap, 0.02);
      EXPECT_EQ(c.time.cfl, 0.6);  // 0.75 of set A's measured limit (docs/validation.md 9.8)
      // The split by its accuracy (docs/presets.md), and the interface solve a thousandth of it (docs/method.md 3.1).
      EXPECT_EQ(c.ggem.tolerance, 1e-2);
      EXPECT_EQ(c.ggem.alpha, 4.0);
      EXPECT_DOUBLE_EQ(c.gmres.tolerance, 1e-5);
      ASSERT_TRUE(c.time.reference_ca);
      EXPECT_EQ(*c.time.reference_ca, ca1);
      EXPECT_EQ(*c.time.end, 2500.0);
      EXPECT_EQ(c.output.every, 0.1);
      EXPECT_EQ(c.output.frames_every, 2.0);
      EXPECT_EQ(c.output.profile_bins, 50);
      EXPECT_TRUE(c.capsules.velocity_projection);
      EXPECT_TRUE(c.capsules.volume_correction);
    }
  }
}

TEST(Presets, BoxesAreTheInferredOnes) {
  // docs/analysis.md §2: phi = 0.2000 / 0.1200 to four digits; the cube of side 10.155 for A, C, D; H 6.667 with
  // Lx = Lz = 12.533 for B.
  if (source_dir().empty()) GTEST_SKIP() << "CAPSFLOW_SOURCE_DIR not set";
  for (const char* s : {"a", "b", "c", "d"}) {
    SCOPED_TRACE(s);
    const Config c = load_config(preset(std::string("set_") + s));
    const bool b = std::string(s) == "b";
    EXPECT_EQ(c.domain.H, b ? 6.667 : 10.155);
    EXPECT_EQ(c.domain.Lx, b ? 12.533 : 10.155);
    EXPECT_EQ(c.domain.Lz, c.domain.Lx);
    const double phi =
        static_cast<double>(*c.suspension->count) * 4.0 / 3.0 * kPi / (c.domain.H * c.domain.Lx * c.domain.Lz);
    EXPECT_EQ(printed(phi, 4), *c.suspension->count == 50 ? "0.2000" : "0.1200");
    EXPECT_EQ(c.suspension->fractions, (std::vector<double>{0.5, 0.5}));  // runnable as it is: X_f = 0.5
  }
}

TEST(Presets, IsolatedAndPairSeries) {
  if (source_dir().empty()) GTEST_SKIP() << "CAPSFLOW_SOURCE_DIR not set";
  // docs/analysis.md §10: one pinned capsule at (Lx/2, y0, Lz/2) in the set A box, Poiseuille; y0 = 0.25 H by default.
  Config c = load_config(preset("isolated"));
  validate_run_config(c);
  ASSERT_EQ(c.capsule_list.size(), 1u);
  EXPECT_TRUE(c.capsule_list[0].pinned);
  EXPECT_EQ(c.domain.H, 10.155);
  EXPECT_EQ(c.capsule_list[0].center[0], c.domain.Lx / 2);
  EXPECT_EQ(c.capsule_list[0].center[1], 0.25 * c.domain.H);
  EXPECT_EQ(c.capsule_list[0].center[2], c.domain.Lz / 2);
  EXPECT_TRUE(c.time.steady_stop);
  EXPECT_EQ(c.flow.type, FlowType::Poiseuille);
  // The series' lowest height (y0/H = 0.125) passes the wall check; F* by an override of the Ca.
  c = load_config(preset("isolated"),
                  parse_overrides({"capsule.1.center=[5.0775, 1.269375, 5.0775]", "species.1.ca=0.5"}));
  validate_run_config(c);
  EXPECT_EQ(c.species[0].ca, 0.5);

  // docs/analysis.md §12: cube of 30a in shear, Delta y_i = 0.5a about the central plane, x_top - x_bottom = -10a,
  // same z; stop at x_top - x_bottom = +10a.
  c = load_config(preset("pair"));
  validate_run_config(c);
  EXPECT_EQ(c.flow.type, FlowType::Shear);
  EXPECT_EQ(c.domain.H, 30.0);
  EXPECT_EQ(c.domain.Lx, 30.0);
  EXPECT_EQ(c.domain.Lz, 30.0);
  ASSERT_EQ(c.capsule_list.size(), 2u);
  const auto& top = c.capsule_list[0].center;
  const auto& bottom = c.capsule_list[1].center;
  EXPECT_EQ(top[1] - bottom[1], 0.5);
  EXPECT_EQ(top[1] + bottom[1], c.domain.H);
  EXPECT_EQ(top[0] - bottom[0], -10.0);
  EXPECT_EQ(top[0] + bottom[0], c.domain.Lx);
  EXPECT_EQ(top[2], bottom[2]);
  ASSERT_TRUE(c.time.stop_pair_dx);
  EXPECT_EQ(*c.time.stop_pair_dx, 10.0);
  EXPECT_EQ(c.output.every, 0.05);
  // Homogeneous pairs by overriding both Ca.
  c = load_config(preset("pair"), parse_overrides({"species.top.ca=0.1", "species.bottom.ca=0.1"}));
  EXPECT_EQ(c.species[0].ca, c.species[1].ca);
}

TEST(Presets, MemoryEstimatorCountsTheGridByHand) {
  if (source_dir().empty()) GTEST_SKIP() << "CAPSFLOW_SOURCE_DIR not set";
  // The pair box at the seed's alpha = 4: h_m = 0.5 / 4 = 0.125, nx = nz = 30 / 0.125 = 240 (2^4 3 5: a fast size),
  // Chebyshev N >= pi H / (2 h_m) = ceil(pi 30 / 0.25) = 377 -> 378 (2 3^3 7, "midchannel"): 379 points across.
  const Config c = load_config(preset("pair"), parse_overrides({"ggem.alpha=4"}));
  const RunSize s = run_size(c);
  EXPECT_EQ(s.grid.nx, 240);
  EXPECT_EQ(s.grid.nz, 240);
  EXPECT_EQ(s.grid.ny, 378);
  EXPECT_EQ(s.grid_points, 21830400u);  // 240 * 240 * 379: "about 22 million" (docs/presets.md)
  EXPECT_EQ(s.capsules, 2);
  EXPECT_EQ(s.nodes, 324);
  EXPECT_EQ(s.wall_points, 115200u);
  // By hand: forcing + velocity 6 * 379 * 57600 * 8 = 1047859200; spectra 3 * 379 * (240 * 121) * 16 =
  // 528295680; wall maps 6 * 57600 * 8 = 2764800 and their spectra 6 * 29040 * 16 = 2787840; Chebyshev points
  // 379 * 8 = 3032: 1581710552. Mode blocks: 121 |kx| x ceil(121 / 16) = 8 blocks of 16 lanes = 968, each with
  // phi, psi (2 * 379 * 16) and the 2x2 inverses (4 * 16), 12192 doubles, and the tau factors: p, q, r over
  // 2 * (378 / 2 + 2) = 382 rows, 1146, and per lane lambda, 382 reciprocals and 2 sums, 16 * 385 = 6160: 19498
  // doubles, 968 * 19498 * 8 = 150992512 bytes, and 968 TauLanes views.
  const MemoryEstimate m = estimate_memory(s);
  EXPECT_EQ(m.grid, 1581710552u + 150992512u + 968u * sizeof(TauLanes));
  EXPECT_GT(m.total(), m.grid);
  EXPECT_LT(m.total(), m.grid + 64u * 1024u * 1024u);  // the grid dominates a box this large
  // Set A at the split's defaults: h_m = 0.125, 10.155 / 0.125 = 81.2 -> 84 (2^2 3 7), N >= pi 4 10.155 = 127.6 ->
  // 128: 84 x 84 x 129.
  const RunSize a = run_size(load_config(preset("set_a"), parse_overrides({"ggem.tolerance=0"})));
  EXPECT_EQ(a.grid_points, 84u * 84u * 129u);
  EXPECT_EQ(a.nodes, 50 * 162);
  // At the preset's tolerance 1e-2: alpha h_m = sqrt(1.15 / ln(24)) = 0.6019, h_m = 0.15048, 67.49 -> 70 (2 5 7);
  // N >= pi 10.155 / (2 h_m) = 106.0 -> 108 (2^2 3^3): 70 x 70 x 109.
  const RunSize at = run_size(load_config(preset("set_a")));
  EXPECT_EQ(at.grid.nx, 70);
  EXPECT_EQ(at.grid.nz, 70);
  EXPECT_EQ(at.grid.ny, 108);
}

TEST(Presets, CostEstimateFollowsTheStepRule) {
  if (source_dir().empty()) GTEST_SKIP() << "CAPSFLOW_SOURCE_DIR not set";
  // Paper rule (at KG's cfl 0.5): steps per strain unit = 1 / (cfl Ca_ref h): set A (Ca_ref 0.2) from a fresh
  // placement (h = 0.147a, level 2) and developed (h = 0.05a); set D's stiff Ca 0.1 doubles both; explicit capsules
  // keep the fresh rate.
  const auto paper = parse_overrides({"time.step_rule=\"paper\"", "time.cfl=0.5"});
  const Config a = load_config(preset("set_a"), paper), d = load_config(preset("set_d"), paper),
               p = load_config(preset("pair"), paper);
  const CostEstimate ea = estimate_cost(a, run_size(a), 2), ed = estimate_cost(d, run_size(d), 2);
  EXPECT_DOUBLE_EQ(ea.steps_per_strain_start, 1.0 / (0.5 * 0.2 * 0.147));
  EXPECT_DOUBLE_EQ(ea.steps_per_strain_developed, 1.0 / (0.5 * 0.2 * 0.05));
  EXPECT_DOUBLE_EQ(ed.steps_per_strain_start, 2.0 * ea.steps_per_strain_start);
  EXPECT_DOUBLE_EQ(ed.steps_per_strain_developed, 2.0 * ea.steps_per_strain_developed);
  EXPECT_FALSE(ea.dilute);
  // The first 2 strain units at the fresh rate, the other 2498 at the developed one.
  EXPECT_DOUBLE_EQ(ea.total_seconds, ea.seconds_per_step * (2.0 * ea.steps_per_strain_start +
                                                            2498.0 * ea.steps_per_strain_developed));
  const CostEstimate ep = estimate_cost(p, run_size(p), 2);
  EXPECT_TRUE(ep.dilute);
  EXPECT_EQ(ep.steps_per_strain_developed, ep.steps_per_strain_start);
  // A level-3 mesh halves the fresh h (twice the steps); the developed h stays gap-limited.
  const Config a3 = load_config(preset("set_a"), parse_overrides({"capsules.mesh_level=3", "time.step_rule=\"paper\"", "time.cfl=0.5"}));
  const CostEstimate e3 = estimate_cost(a3, run_size(a3), 2);
  EXPECT_DOUBLE_EQ(e3.steps_per_strain_start, 2.0 * ea.steps_per_strain_start);
  EXPECT_DOUBLE_EQ(e3.steps_per_strain_developed, ea.steps_per_strain_developed);
  // Serial costs 1.9x two threads (docs/performance.md section 6: 198.9 ms against 104.2 ms).
  EXPECT_NEAR(estimate_cost(a, run_size(a), 1).seconds_per_step / ea.seconds_per_step, 1.9, 1e-12);
  // Membrane rule (the default): h is the shortest edge, 0.227a at level 2, fresh or developed; the developed rate
  // carries the near-contact factor; a level-3 mesh halves h.
  const Config am = load_config(preset("set_a"));
  ASSERT_EQ(am.time.step_rule, StepRule::Membrane);
  const CostEstimate em = estimate_cost(am, run_size(am), 2);
  EXPECT_DOUBLE_EQ(em.steps_per_strain_start, 1.0 / (0.6 * 0.2 * 0.227));
  EXPECT_DOUBLE_EQ(em.steps_per_strain_developed, 1.0 / (0.6 * am.time.near_contact_factor * 0.2 * 0.227));
  EXPECT_LT(em.total_seconds, ea.total_seconds / 3.0);  // the point of the rule
  const Config am3 = load_config(preset("set_a"), parse_overrides({"capsules.mesh_level=3"}));
  EXPECT_DOUBLE_EQ(estimate_cost(am3, run_size(am3), 2).steps_per_strain_start, 2.0 * em.steps_per_strain_start);
}

// The blood preset (issue 23): 24 red cells (haematocrit 0.196) and 4 platelets, placed at random orientations
// without overlap; the species' values are the file's (the comments name their sources).
TEST(Presets, BloodMarginationPlacesRedCellsAndPlatelets) {
  if (source_dir().empty()) GTEST_SKIP() << "CAPSFLOW_SOURCE_DIR not set";
  const Config c = load_config(preset("blood_margination"));
  validate_run_config(c);
  ASSERT_EQ(c.species.size(), 2u);
  EXPECT_EQ(c.species[1].shape.kind, ShapeKind::Biconcave);
  EXPECT_EQ(c.species_membrane(1).law, MembraneLaw::Skalak);
  EXPECT_EQ(c.species_membrane(1).skalak_C, 10.0);
  EXPECT_EQ(c.species_membrane(1).inflation, 0.0);
  EXPECT_EQ(c.species[1].bending_modulus, 0.01);
  EXPECT_EQ(c.species[0].shape.kind, ShapeKind::Spheroid);
  EXPECT_LT(c.species[0].ca, c.species[1].ca);  // platelets are the stiff species of the analysis
  const std::vector<CapsulePlacement> p = place_capsules(c);
  ASSERT_EQ(p.size(), 28u);
  long cells = 0;
  for (const CapsulePlacement& q : p) cells += q.species == 1;
  EXPECT_EQ(cells, 24);
  const double ht = 24 * 4.0 / 3.0 * kPi / (c.domain.H * c.domain.Lx * c.domain.Lz);
  EXPECT_NEAR(ht, 0.2, 0.005);
  // The cost estimate takes the stiffest capsule's law factor: Skalak C = 10 at rest is 5.5x neo-Hookean.
  const CostEstimate e = estimate_cost(c, run_size(c), 2);
  EXPECT_DOUBLE_EQ(e.ca_ref, 0.3 / 5.5);
}

}  // namespace
}  // namespace capsflow
