// Analysis library (issue 9; docs/analysis.md §3-§14): every quantity against an answer the test computes on its own
// from the construction of a synthetic run, never from the library's output.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "host/analysis/analysis.hpp"
#include "host/analysis/analysis_dynamics.hpp"
#include "host/analysis/analysis_profiles.hpp"
#include "host/base/errors.hpp"
#include "host/state/icosphere.hpp"
#include "kernels/slab_volume.hpp"

using namespace capsflow;
using namespace capsflow::analysis;

namespace {

constexpr double kPi = 3.14159265358979323846;

// A run with T records at t = t_index * dt, all capsules at the origin with zero velocity.
RunSeries make_run(double H, std::size_t T, double dt, const std::vector<double>& ca, const std::vector<int>& species) {
  RunSeries r;
  r.label = "synthetic";
  r.H = r.Lx = r.Lz = H;
  r.np = ca.size();
  r.ca = ca;
  r.species = species;
  r.time.resize(T);
  for (std::size_t t = 0; t < T; ++t) r.time[t] = static_cast<double>(t) * dt;
  r.centroid.assign(3 * T * r.np, 0.0);
  r.velocity.assign(3 * T * r.np, 0.0);
  return r;
}
void set_y(RunSeries& r, std::size_t t, std::size_t i, double y) { r.centroid[3 * (t * r.np + i) + 1] = y; }
void set_x(RunSeries& r, std::size_t t, std::size_t i, double x) { r.centroid[3 * (t * r.np + i)] = x; }
void set_uy(RunSeries& r, std::size_t t, std::size_t i, double u) { r.velocity[3 * (t * r.np + i) + 1] = u; }

RunGroup group_of(std::vector<RunSeries> runs, double ca_stiff = 0.2, double ca_floppy = 0.5) {
  RunGroup g;
  g.key = composition_key(runs.front());
  g.ca = {ca_stiff, ca_floppy};
  g.runs = std::move(runs);
  return g;
}

double sum(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x;
  return s;
}

}  // namespace

// ---------------------------------------------------------------------------------------------------------------
// Folding, species, windows (§1, §3)

TEST(AnalysisBasics, FoldingOfHeightVelocityAndBins) {
  EXPECT_DOUBLE_EQ(fold_y(2.0, 10.0), 2.0);
  EXPECT_DOUBLE_EQ(fold_y(8.0, 10.0), 2.0);
  EXPECT_DOUBLE_EQ(fold_velocity(2.0, 0.3, 10.0), 0.3);   // lower half: toward the centreline is +y
  EXPECT_DOUBLE_EQ(fold_velocity(8.0, 0.3, 10.0), -0.3);  // upper half: toward the centreline is -y
  EXPECT_EQ(folded_bin(0.1, 10.0, 25), 0);                // bins of width 0.2
  EXPECT_EQ(folded_bin(9.9, 10.0, 25), 0);
  EXPECT_EQ(folded_bin(1.05, 10.0, 25), 5);
  EXPECT_EQ(folded_bin(5.0, 10.0, 25), 24);  // the centreline falls in the last bin
  EXPECT_EQ(folded_bin(-0.1, 10.0, 25), 0);  // clamped
}

TEST(AnalysisBasics, StiffIsTheSmallerCapillaryNumberAndRunsGroupByComposition) {
  RunSeries a = make_run(10.0, 3, 1.0, {0.5, 0.2, 0.5}, {0, 1, 0});
  RunSeries b = a;
  b.label = "seed 2";
  RunSeries c = make_run(10.0, 3, 1.0, {0.2, 0.2, 0.2}, {0, 0, 0});
  const SpeciesCa ca = identify_species({a, b, c});
  EXPECT_DOUBLE_EQ(ca.stiff, 0.2);
  EXPECT_DOUBLE_EQ(ca.floppy, 0.5);
  EXPECT_EQ(species_mask(a, Species::Stiff, ca), (std::vector<char>{0, 1, 0}));
  EXPECT_EQ(species_mask(a, Species::Floppy, ca), (std::vector<char>{1, 0, 1}));
  EXPECT_EQ(species_count(a, Species::All, ca), 3u);
  EXPECT_THROW(identify_species({c}), InputError);  // one Ca: cannot tell which species it is
  RunSeries d = make_run(10.0, 3, 1.0, {0.1, 0.2, 0.5}, {0, 1, 2});
  EXPECT_THROW(identify_species({d}), InputError);  // three
  EXPECT_THROW(belongs(0.3, Species::Stiff, ca), InputError);

  const auto groups = group_runs({a, c, b}, ca);
  ASSERT_EQ(groups.size(), 2u);
  EXPECT_EQ(groups[0].runs.size(), 2u);  // a and b: realizations
  EXPECT_EQ(groups[0].runs[1].label, "seed 2");
  EXPECT_EQ(groups[1].runs.size(), 1u);
  EXPECT_NEAR(floppy_fraction(groups[0]), 2.0 / 3.0, 1e-15);
  EXPECT_EQ(floppy_fraction(groups[1]), 0.0);
}

TEST(AnalysisBasics, ValidationRejectsMalformedRuns) {
  RunSeries a = make_run(10.0, 3, 1.0, {0.2}, {0});
  a.velocity.pop_back();
  EXPECT_THROW(validate(a), InputError);
  RunSeries b = make_run(10.0, 3, 1.0, {0.2}, {0});
  b.time[2] = b.time[1];
  EXPECT_THROW(validate(b), InputError);
  RunSeries c = make_run(10.0, 3, 1.0, {0.2}, {0});
  c.slab_bins = 50;
  c.slab_species = 1;
  c.slab_volume.assign(10, 0.0);
  EXPECT_THROW(validate(c), InputError);
}

TEST(AnalysisBasics, WindowIsTheLastThousandOrTheSecondHalf) {
  AnalysisOptions opt;
  const RunSeries longrun = make_run(10.0, 25001, 0.1, {0.2}, {0});
  const Window w = steady_window(longrun, opt);
  EXPECT_NEAR(w.t0, 1500.0, 1e-9);
  EXPECT_NEAR(w.t1, 2500.0, 1e-9);
  EXPECT_NE(w.rule.find("last 1000"), std::string::npos);
  const RunSeries shortrun = make_run(10.0, 1501, 1.0, {0.2}, {0});
  const Window s = steady_window(shortrun, opt);
  EXPECT_DOUBLE_EQ(s.t0, 750.0);
  EXPECT_DOUBLE_EQ(s.t1, 1500.0);
  EXPECT_NE(s.rule.find("second half"), std::string::npos);
  opt.window_start = 100.0;
  opt.window_end = 5000.0;
  const Window e = steady_window(shortrun, opt);
  EXPECT_DOUBLE_EQ(e.t0, 100.0);
  EXPECT_DOUBLE_EQ(e.t1, 1500.0);
  EXPECT_NE(e.rule.find("clipped"), std::string::npos);
  // Blocks of equal duration; the end of the window belongs to the last block.
  const auto b = record_blocks({0.0, 0.5, 1.0, 1.99, 2.0, 2.5}, Window{0.0, 2.0, ""}, 4);
  EXPECT_EQ(b, (std::vector<int>{0, 1, 2, 3, 3, -1}));
}

// ---------------------------------------------------------------------------------------------------------------
// Error bars (§4)

TEST(AnalysisStatistics, BlockSeOfIidSeriesIsSigmaOverSqrtN) {
  const std::size_t N = 200000;
  const double sigma = 2.0;
  std::mt19937_64 rng(7);
  std::normal_distribution<double> g(1.5, sigma);
  std::vector<double> time(N), x(N);
  for (std::size_t i = 0; i < N; ++i) {
    time[i] = 0.01 * static_cast<double>(i);
    x[i] = g(rng);
  }
  const int nb = 100;
  const auto blk = record_blocks(time, Window{0.0, time.back(), ""}, nb);
  std::vector<double> s(nb, 0.0), c(nb, 0.0);
  for (std::size_t i = 0; i < N; ++i) {
    s[static_cast<std::size_t>(blk[i])] += x[i];
    c[static_cast<std::size_t>(blk[i])] += 1.0;
  }
  for (int b = 0; b < nb; ++b) {
    ASSERT_GT(c[b], 1900.0);
    s[b] /= c[b];
  }
  const Estimate e = block_average(s);
  ASSERT_TRUE(e.defined);
  const double expect = sigma / std::sqrt(static_cast<double>(N));
  EXPECT_NEAR(e.se / expect, 1.0, 0.2);  // relative scatter of a 100-block SE: 1/sqrt(198) = 7%
  EXPECT_NEAR(e.value, 1.5, 4.0 * expect);
  EXPECT_FALSE(block_average({3.0}).se == block_average({3.0}).se);  // one block: no error bar (NaN)
}

TEST(AnalysisStatistics, JackknifeOfMeanEqualsClassicalStandardError) {
  // Blocks (x_b, 1): the delete-one jackknife of sum x / sum 1 is the textbook SE of the mean, exactly.
  const std::vector<double> x = {1.0, 4.0, 2.5, -0.5, 3.0, 7.0, 0.25};
  std::vector<std::vector<double>> blocks;
  for (double v : x) blocks.push_back({v, 1.0});
  const auto jk = jackknife(blocks, [](const std::vector<double>& s) { return std::vector<double>{s[0] / s[1]}; });
  const double n = static_cast<double>(x.size()), m = sum(x) / n;
  double ss = 0.0;
  for (double v : x) ss += (v - m) * (v - m);
  EXPECT_NEAR(jk.value[0], m, 1e-14);
  EXPECT_NEAR(jk.se[0], std::sqrt(ss / (n * (n - 1.0))), 1e-14);
  EXPECT_EQ(jk.blocks, 7);
  // Empty blocks are not counted.
  blocks.push_back({0.0, 0.0});
  EXPECT_EQ(jackknife(blocks, [](const std::vector<double>& s) { return std::vector<double>{s[0] / s[1]}; }).blocks, 7);
}

TEST(AnalysisStatistics, JackknifeOfRatio) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0.5, 1.5);
  const int n = 400;
  std::vector<double> a(n), b(n);
  for (int i = 0; i < n; ++i) {
    b[i] = u(rng);
    a[i] = 0.3 * b[i] + 0.1 * (u(rng) - 1.0);
  }
  const Estimate e = jackknife_ratio(a, b);
  // Delete-one replicates written out here.
  const double A = sum(a), B = sum(b);
  std::vector<double> rep(n);
  for (int i = 0; i < n; ++i) rep[i] = (A - a[i]) / (B - b[i]);
  const double rm = sum(rep) / n;
  double ss = 0.0;
  for (double r : rep) ss += (r - rm) * (r - rm);
  EXPECT_NEAR(e.value, A / B, 1e-14);
  EXPECT_NEAR(e.se, std::sqrt((n - 1.0) / n * ss), 1e-12);
  // ... and the delta method for i.i.d. blocks: SE^2 = sum (a_b - R b_b)^2 / (n (n-1) bbar^2).
  const double R = A / B, bbar = B / n;
  double d = 0.0;
  for (int i = 0; i < n; ++i) d += (a[i] - R * b[i]) * (a[i] - R * b[i]);
  EXPECT_NEAR(e.se, std::sqrt(d / (n * (n - 1.0))) / bbar, 0.02 * e.se);
  // An exact ratio has no scatter; a zero denominator is undefined.
  const Estimate exact = jackknife_ratio({1.0, 2.0, 3.0}, {2.0, 4.0, 6.0});
  EXPECT_NEAR(exact.value, 0.5, 1e-15);
  EXPECT_NEAR(exact.se, 0.0, 1e-15);
  EXPECT_FALSE(jackknife_ratio({1.0, 2.0}, {0.0, 0.0}).defined);
}

// ---------------------------------------------------------------------------------------------------------------
// Profiles (§6-§9)

namespace {

// np capsules placed independently and uniformly in [a, H - a] at every record, with U_y = c (H/2 - y).
RunSeries uniform_run(double H, double a, std::size_t np, std::size_t T, double c, std::uint64_t seed) {
  std::vector<double> ca(np, 0.2);
  std::vector<int> sp(np, 0);
  for (std::size_t i = 0; i < np; i += 5) {  // every fifth capsule floppy
    ca[i] = 0.5;
    sp[i] = 1;
  }
  RunSeries r = make_run(H, T, 1.0, ca, sp);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(a, H - a);
  for (std::size_t t = 0; t < T; ++t)
    for (std::size_t i = 0; i < np; ++i) {
      const double y = u(rng);
      set_y(r, t, i, y);
      set_uy(r, t, i, c * (0.5 * H - y));
    }
  return r;
}

}  // namespace

TEST(AnalysisProfiles, UniformPlacementGivesFlatNumberDensityAndKnownDBar) {
  // H = 10, a = 1: bins of 0.2, so y' = a is the edge of bin 5. Window: last 1000 of 2000 (1001 records).
  const double H = 10.0, a = 1.0;
  const std::size_t np = 50;
  const RunGroup g = group_of({uniform_run(H, a, np, 2001, 0.0, 11)});
  AnalysisOptions opt;
  opt.blocks = 50;  // 50 blocks: the SE estimates scatter by 10%, so their check can be tight
  const Profile n = number_density(g, Species::All, opt);
  ASSERT_EQ(n.value.size(), 25u);
  const double inside = H / (H - 2.0 * a);  // the uniform check of §6
  const double N = 1001.0 * np, p = 0.2 / (0.5 * H - a);  // samples; probability of one inside bin
  const double se_theory = std::sqrt(N * p * (1.0 - p)) / (N / 25.0);
  double integral = 0.0;
  for (std::size_t k = 0; k < 25; ++k) {
    ASSERT_TRUE(n.defined[k]);
    integral += 2.0 / H * n.value[k] * (H / 50.0);
    if (k < 5) {
      EXPECT_EQ(n.value[k], 0.0) << k;
      continue;
    }
    EXPECT_NEAR(n.value[k], inside, 4.0 * se_theory) << k;
    EXPECT_GT(n.se[k], 0.5 * se_theory) << k;
    EXPECT_LT(n.se[k], 1.7 * se_theory) << k;
  }
  EXPECT_NEAR(integral, 1.0, 1e-12);

  // d-bar / (H/2) = (1 - 2a/H) / 2 (the uniform check of §5); d/(H/2) per sample is uniform on [0, 1 - 2a/H].
  const DBar d = steady_d_bar(g, Species::All, opt);
  ASSERT_TRUE(d.d.defined);
  const DBar d10 = steady_d_bar(g, Species::All, AnalysisOptions{});
  const double width = 1.0 - 2.0 * a / H, se_d = width / std::sqrt(12.0) / std::sqrt(N);
  EXPECT_NEAR(d.d.value, width / 2.0, 4.0 * se_d);
  EXPECT_GT(d.d.se, 0.5 * se_d);
  EXPECT_LT(d.d.se, 1.7 * se_d);
  ASSERT_EQ(d10.block_length.size(), 3u);  // §4: 50, 100, 200 strain
  EXPECT_DOUBLE_EQ(d10.block_length[0], 50.0);
  EXPECT_DOUBLE_EQ(d10.block_length[1], 100.0);
  EXPECT_DOUBLE_EQ(d10.block_length[2], 200.0);
  EXPECT_NEAR(d10.d.value, d.d.value, 1e-3);
  EXPECT_TRUE(d10.plateau);  // i.i.d. records: no correlation to outgrow
  EXPECT_TRUE(d10.windows[0].rule.find("last 1000") != std::string::npos);
  // Per species the same law holds; the floppy subset is every fifth capsule.
  const DBar dfl = steady_d_bar(g, Species::Floppy, opt);
  EXPECT_NEAR(dfl.d.value, width / 2.0, 4.0 * se_d * std::sqrt(5.0));
}

TEST(AnalysisProfiles, NumberDensityOfAbsentSpeciesIsUndefined) {
  RunSeries r = make_run(10.0, 20, 1.0, {0.2, 0.2}, {0, 0});
  const Profile n = number_density(group_of({r}), Species::Floppy, AnalysisOptions{});
  EXPECT_FALSE(n.any_defined());
  EXPECT_FALSE(n.reason.empty());
}

namespace {

// Capsules as level-2 icospheres of radius 1 at random heights in [1.05, H - 1.05]; the per-species slab volumes
// of every record are recorded with the kernel, and the volume series with the polyhedron volume.
RunSeries mesh_run(double H, std::size_t np, std::size_t T, int slab_bins, std::uint64_t seed) {
  std::vector<double> ca(np, 0.2);
  std::vector<int> sp(np, 0);
  for (std::size_t i = 0; i < np; i += 3) {
    ca[i] = 0.5;
    sp[i] = 1;
  }
  RunSeries r = make_run(H, T, 1.0, ca, sp);
  r.slab_bins = slab_bins;
  r.slab_species = 2;
  r.slab_volume.assign(T * 2 * static_cast<std::size_t>(slab_bins), 0.0);
  r.volume.assign(T * np, 0.0);
  const TriMesh& m = icosphere(2);
  const int nv = m.num_nodes();
  std::vector<double> x(np * nv), y(np * nv), z(np * nv);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(1.05, H - 1.05);
  double vmesh = 0.0;
  for (int t = 0; t < m.num_triangles(); ++t) {  // polyhedron volume, tetrahedra from the centre
    const int* q = &m.tri[3 * t];
    vmesh += (m.x[q[0]] * (m.y[q[1]] * m.z[q[2]] - m.z[q[1]] * m.y[q[2]]) -
              m.y[q[0]] * (m.x[q[1]] * m.z[q[2]] - m.z[q[1]] * m.x[q[2]]) +
              m.z[q[0]] * (m.x[q[1]] * m.y[q[2]] - m.y[q[1]] * m.x[q[2]])) /
             6.0;
  }
  for (std::size_t t = 0; t < T; ++t) {
    for (std::size_t k = 0; k < np; ++k) {
      const double yc = u(rng);
      set_y(r, t, k, yc);
      r.volume[t * np + k] = vmesh;
      for (int i = 0; i < nv; ++i) {
        x[k * nv + i] = m.x[i];
        y[k * nv + i] = yc + m.y[i];
        z[k * nv + i] = m.z[i];
      }
    }
    species_slab_volumes(static_cast<int>(np), nv, m.num_triangles(), m.tri.data(), x.data(), y.data(), z.data(),
                         r.species.data(), H, slab_bins, r.slab_volume.data() + t * 2 * slab_bins);
  }
  return r;
}

}  // namespace

TEST(AnalysisProfiles, PhiHatFromMeshSlabsIntegratesToOneAndMatchesSphereModel) {
  const double H = 10.0;
  const RunGroup g = group_of({mesh_run(H, 12, 400, 100, 5), mesh_run(H, 12, 400, 100, 6)});
  const AnalysisOptions opt;
  for (Species s : {Species::Stiff, Species::Floppy, Species::All}) {
    const auto mesh = volume_fraction_profile(g, s, opt, VolumeSource::MeshSlabs);
    const auto sph = volume_fraction_profile(g, s, opt, VolumeSource::Spheres);
    ASSERT_TRUE(mesh.phi_hat.any_defined()) << mesh.phi_hat.reason;
    double integral = 0.0, integral_s = 0.0;
    for (std::size_t k = 0; k < 25; ++k) {
      integral += 2.0 / H * mesh.phi_hat.value[k] * (H / 50.0);
      integral_s += 2.0 / H * sph.phi_hat.value[k] * (H / 50.0);
    }
    EXPECT_NEAR(integral, 1.0, 1e-12) << species_name(s);
    EXPECT_NEAR(integral_s, 1.0, 1e-12) << species_name(s);
    // The same capsules as polyhedra and as spheres of equal volume: profiles agree to the mesh resolution.
    EXPECT_LT(max_abs_difference(mesh.phi_hat, sph.phi_hat), 2e-3) << species_name(s);
    // phi-bar: the capsules' volume over the box, measured and nominal (a = 1; the mesh is inscribed).
    const double nx = static_cast<double>(species_count(g.runs[0], s, g.ca));
    EXPECT_NEAR(mesh.phi_bar, nx * g.runs[0].volume[0] / (H * H * H), 1e-12);
    EXPECT_NEAR(mesh.phi_bar_nominal, nx * 4.0 / 3.0 * kPi / (H * H * H), 1e-14);
    // phi (un-normalised) = phi-hat * phi-bar.
    for (std::size_t k = 0; k < 25; ++k) EXPECT_NEAR(mesh.phi.value[k], mesh.phi_hat.value[k] * mesh.phi_bar, 1e-12);
  }
  // Slab counts that do not put the folded edges on slab edges are refused with a reason.
  RunGroup bad = g;
  for (auto& r : bad.runs) {
    r.slab_bins = 40;
    r.slab_volume.resize(r.records() * 2 * 40);
  }
  const auto p = volume_fraction_profile(bad, Species::All, opt);
  EXPECT_FALSE(p.phi_hat.any_defined());
  EXPECT_NE(p.phi_hat.reason.find("multiple of 50"), std::string::npos);
}

TEST(AnalysisProfiles, SphereModelSlabsAreSphericalCaps) {
  RunSeries r = make_run(10.0, 1, 1.0, {0.2}, {0});
  r.volume = {4.0 / 3.0 * kPi * 1.2 * 1.2 * 1.2};  // radius 1.2
  set_y(r, 0, 0, 3.0);
  const auto s = sphere_slab_volumes(r, 10);  // slabs of 1.0
  ASSERT_EQ(s.size(), 10u);
  const auto cap = [](double h) { return kPi * h * h * (3.0 * 1.2 - h) / 3.0; };  // h measured from y = 1.8
  EXPECT_EQ(s[0], 0.0);
  EXPECT_NEAR(s[1], cap(0.2), 1e-14);
  EXPECT_NEAR(s[2], cap(1.2) - cap(0.2), 1e-14);
  EXPECT_NEAR(s[3], cap(2.2) - cap(1.2), 1e-14);
  EXPECT_NEAR(s[4], cap(2.4) - cap(2.2), 1e-14);
  EXPECT_NEAR(sum(s), r.volume[0], 1e-13);
}

namespace {

// A two-species run whose folded slab profile is set directly: folded bin k holds v_s(k) of the stiff and v_f(k)
// of the floppy capsules at every record (half in each slab of the pair). 8 stiff + 2 floppy capsules: X_f = 0.2.
RunSeries slab_profile_run(const std::vector<double>& vs, const std::vector<double>& vf, std::size_t T) {
  RunSeries r = make_run(10.0, T, 1.0, {0.2, 0.2, 0.2, 0.2, 0.2, 0.2, 0.2, 0.2, 0.5, 0.5}, {0, 0, 0, 0, 0, 0, 0, 0, 1, 1});
  r.slab_bins = 50;
  r.slab_species = 2;
  r.slab_volume.assign(T * 2 * 50, 0.0);
  for (std::size_t t = 0; t < T; ++t)
    for (std::size_t k = 0; k < 25; ++k)
      for (std::size_t j : {k, 49 - k}) {
        r.slab_volume[(t * 2 + 0) * 50 + j] = 0.5 * vs[k];
        r.slab_volume[(t * 2 + 1) * 50 + j] = 0.5 * vf[k];
      }
  return r;
}

}  // namespace

TEST(AnalysisProfiles, TwoSpeciesSlabProfileHasKnownEnrichment) {
  // Bins 0, 1 empty (masked); 2..11: stiff-rich (3 : 0.5); 12..24: equal (1 : 1).
  std::vector<double> vs(25), vf(25);
  for (std::size_t k = 0; k < 25; ++k) {
    vs[k] = k < 2 ? 0.0 : (k < 12 ? 3.0 : 1.0);
    vf[k] = k < 2 ? 0.0 : (k < 12 ? 0.5 : 1.0);
  }
  const RunGroup g = group_of({slab_profile_run(vs, vf, 300)});
  const AnalysisOptions opt;
  const Enrichment e = enrichment(g, opt);
  const double xf = 0.2;
  EXPECT_NEAR(e.xf, xf, 1e-15);
  for (std::size_t k = 0; k < 25; ++k) {
    if (k < 2) {
      EXPECT_FALSE(e.xf_tilde.defined[k]) << k;
      continue;
    }
    const double tilde = vf[k] / (vs[k] + vf[k]);
    EXPECT_NEAR(e.xf_tilde.value[k], tilde, 1e-14) << k;
    EXPECT_NEAR(e.xf_hat.value[k], tilde / xf, 1e-14) << k;
    EXPECT_NEAR(e.xf_hat.se[k], 0.0, 1e-12) << k;  // the same profile in every block
  }
  // R_f = bins 12..24: E_f = (1/X_f) 13 / 26; R_s = bins 2..11: E_s = (1/X_s) 30 / 35.
  ASSERT_TRUE(e.E_f.defined) << e.E_f.reason;
  EXPECT_NEAR(e.E_f.value, 5.0 * 13.0 / 26.0, 1e-13);
  EXPECT_NEAR(e.E_s.value, 1.25 * 30.0 / 35.0, 1e-13);
  EXPECT_NEAR(e.E_f_contiguous.value, e.E_f.value, 1e-13);  // one crossing: the two definitions coincide
  EXPECT_NEAR(e.E_s_contiguous.value, e.E_s.value, 1e-13);
  const double h11 = (0.5 / 3.5) / xf, h12 = 0.5 / xf;
  EXPECT_NEAR(e.y_star_over_H.value, (11.5 + (1.0 - h11) / (h12 - h11)) / 50.0, 1e-14);
  EXPECT_NEAR(e.xf_volume, 18.0 / 61.0, 1e-14);
  EXPECT_TRUE(e.xf_volume_flag);  // 0.295 vs 0.2

  // phi-hat of each species from the same slabs: 25 v(k) / sum v.
  const auto ps = volume_fraction_profile(g, Species::Stiff, opt);
  for (std::size_t k = 0; k < 25; ++k) EXPECT_NEAR(ps.phi_hat.value[k], 25.0 * vs[k] / sum(vs), 1e-13) << k;
  EXPECT_NEAR(ps.phi.value[5], 3.0 / (10.0 * 10.0 * 0.4), 1e-14);  // v / (Lx Lz 2 dy)

  // A noisy near-wall bin that is floppy-rich: the literal region picks it up, the contiguous one does not.
  vs[2] = 0.2;
  vf[2] = 0.8;
  const Enrichment e2 = enrichment(group_of({slab_profile_run(vs, vf, 300)}), opt);
  EXPECT_NEAR(e2.E_f.value, 5.0 * 13.8 / 27.0, 1e-13);
  EXPECT_NEAR(e2.E_f_contiguous.value, 5.0 * 13.0 / 26.0, 1e-13);
  EXPECT_NEAR(e2.E_s.value, 1.25 * 27.0 / 31.5, 1e-13);            // bins 3..11
  EXPECT_NEAR(e2.E_s_contiguous.value, 1.25 * 27.2 / 32.5, 1e-13);  // bins 2..11
  EXPECT_NEAR(e2.y_star_over_H.value, e.y_star_over_H.value, 1e-15);
}

TEST(AnalysisProfiles, EnrichmentFactorsAreAtLeastOneAndUndefinedForPureSuspensions) {
  std::mt19937_64 rng(19);
  std::uniform_real_distribution<double> u(0.2, 1.0);
  for (int nf : {2, 4, 6, 8}) {  // X_f = 0.2 .. 0.8 of 10 capsules
    std::vector<double> ca(10, 0.2);
    std::vector<int> sp(10, 0);
    for (int i = 0; i < nf; ++i) {
      ca[static_cast<std::size_t>(i)] = 0.5;
      sp[static_cast<std::size_t>(i)] = 1;
    }
    RunSeries r = make_run(10.0, 200, 1.0, ca, sp);
    r.slab_bins = 100;
    r.slab_species = 2;
    r.slab_volume.resize(200 * 2 * 100);
    // Random slab volumes, the floppy slot scaled so that its volume share is X_f on average.
    const double scale = nf / (10.0 - nf);
    for (std::size_t j = 0; j < r.slab_volume.size(); ++j) r.slab_volume[j] = u(rng) * ((j / 100) % 2 ? scale : 1.0);
    const Enrichment e = enrichment(group_of({r}), AnalysisOptions{});
    ASSERT_TRUE(e.E_f.defined && e.E_s.defined) << e.E_f.reason << e.E_s.reason;
    EXPECT_GE(e.E_f.value, 1.0);
    EXPECT_GE(e.E_s.value, 1.0);
    EXPECT_GT(e.E_f.se, 0.0);
  }
  std::vector<double> vs(25, 1.0), vf(25, 0.0);
  RunSeries pure = slab_profile_run(vs, vf, 50);
  std::fill(pure.ca.begin(), pure.ca.end(), 0.2);
  std::fill(pure.species.begin(), pure.species.end(), 0);
  const Enrichment e = enrichment(group_of({pure}), AnalysisOptions{});
  EXPECT_EQ(e.xf, 0.0);
  EXPECT_FALSE(e.E_f.defined);
  EXPECT_FALSE(e.E_s.defined);
  EXPECT_NE(e.E_f.reason.find("pure suspension"), std::string::npos);
}

TEST(AnalysisProfiles, FoldedVelocityOfCentreSeekingFieldIsPositive) {
  // U_y = c (H/2 - y): every capsule moves toward the centreline, so v_p = c |H/2 - y| = c (H/2 - y') > 0.
  const double H = 10.0, a = 1.0, c = 0.01;
  const RunGroup g = group_of({uniform_run(H, a, 50, 2001, c, 23)});
  const VelocityProfile vp = velocity_profile(g, Species::All, AnalysisOptions{});
  int defined = 0;
  for (std::size_t k = 0; k < 25; ++k) {
    if (k < 5) {
      EXPECT_FALSE(vp.mean.defined[k]) << k;  // no centroid within a of the wall
      continue;
    }
    ASSERT_TRUE(vp.mean.defined[k]) << k;
    ++defined;
    const double yc = (static_cast<double>(k) + 0.5) * 0.2;
    EXPECT_GT(vp.mean.value[k], 0.0) << k;
    EXPECT_NEAR(vp.mean.value[k], c * (0.5 * H - yc), 0.05 * c * 0.2) << k;  // linear: the bin mean at the centre
    EXPECT_NEAR(vp.fluctuation.value[k], c * 0.2 / std::sqrt(12.0), 0.1 * c * 0.2 / std::sqrt(12.0)) << k;
  }
  EXPECT_EQ(defined, 20);
}

TEST(AnalysisProfiles, VelocityBinsWithFewerThan200SamplesAreMasked) {
  // One capsule: 199 records in bin 10 (y = 2.1), 200 records in bin 20 (y = 4.1), window = whole run.
  RunSeries r = make_run(10.0, 399, 1.0, {0.2}, {0});
  for (std::size_t t = 0; t < 399; ++t) {
    set_y(r, t, 0, t < 199 ? 2.1 : 4.1);
    set_uy(r, t, 0, 0.01);
  }
  AnalysisOptions opt;
  opt.window_start = 0.0;
  opt.window_end = 398.0;
  const VelocityProfile vp = velocity_profile(group_of({r}), Species::Stiff, opt);
  EXPECT_FALSE(vp.mean.defined[10]);
  EXPECT_EQ(vp.mean.samples[10], 199.0);
  EXPECT_TRUE(vp.mean.defined[20]);
  EXPECT_NEAR(vp.mean.value[20], 0.01, 1e-15);
  EXPECT_NEAR(vp.fluctuation.value[20], 0.0, 1e-9);
}

TEST(AnalysisProfiles, RelativeVelocityChangeAgainstPureReference) {
  Profile ref, mix;
  for (Profile* p : {&ref, &mix}) {
    p->y_over_H = {0.1, 0.2, 0.3, 0.4};
    p->samples = {500, 500, 500, 500};
    p->defined = {1, 1, 1, 0};
  }
  ref.value = {0.02, 0.01, 0.001, 0.0};
  ref.se = {0.001, 0.001, 0.001, 0.0};  // bin 2: |v_r| < 2 SE -> masked
  mix.value = {0.01, 0.005, 0.0005, 0.0};
  mix.se = {0.0005, 0.0005, 0.0005, 0.0};
  const Profile d = relative_velocity_change(mix, ref);
  EXPECT_NEAR(d.value[0], -0.5, 1e-15);
  EXPECT_NEAR(d.value[1], -0.5, 1e-15);
  EXPECT_FALSE(d.defined[2]);
  EXPECT_FALSE(d.defined[3]);
  // SE^2 = (SE_v / v_r)^2 + (v SE_r / v_r^2)^2
  EXPECT_NEAR(d.se[0], std::hypot(0.0005 / 0.02, 0.01 * 0.001 / (0.02 * 0.02)), 1e-15);
}

TEST(AnalysisProfiles, VelocityPdfUsesTheHeightWindowAndIsADensity) {
  // Capsule 0 sits at y'/H = 0.2 (inside the window around 0.2) with Gaussian v_p; capsule 1 at y'/H = 0.3 with
  // v_p = 0.25: it must not appear in P(v_p) at 0.2.
  const std::size_t T = 20000;
  RunSeries r = make_run(10.0, T, 0.1, {0.2, 0.2}, {0, 0});
  std::mt19937_64 rng(5);
  std::normal_distribution<double> g(0.01, 0.03);
  for (std::size_t t = 0; t < T; ++t) {
    const bool upper = t % 2;  // alternate halves: the fold must flip U_y
    const double v = g(rng);
    set_y(r, t, 0, upper ? 8.0 : 2.0);
    set_uy(r, t, 0, upper ? -v : v);
    set_y(r, t, 1, 3.0);
    set_uy(r, t, 1, 0.25);
  }
  AnalysisOptions opt;
  opt.window_start = 0.0;
  opt.window_end = 1e9;
  const VelocityPdf pdf = velocity_pdf(group_of({r}), Species::All, 0.2, opt);
  ASSERT_EQ(pdf.samples, T);
  EXPECT_FALSE(pdf.widened);
  ASSERT_EQ(pdf.edges.size(), 151u);
  EXPECT_NEAR(pdf.edges.front(), -0.3, 1e-15);
  EXPECT_NEAR(pdf.edges.back(), 0.3, 1e-12);
  double integral = 0.0;
  for (std::size_t k = 0; k < pdf.density.size(); ++k) integral += pdf.density[k] * (pdf.edges[k + 1] - pdf.edges[k]);
  EXPECT_NEAR(integral, pdf.coverage, 1e-12);
  EXPECT_NEAR(pdf.coverage, 1.0, 1e-12);
  EXPECT_NEAR(pdf.mean, 0.01, 4.0 * 0.03 / std::sqrt(static_cast<double>(T)));
  EXPECT_NEAR(pdf.stddev, 0.03, 0.03 * 0.03);
  // The peak bin of a Gaussian: density ~ 1 / (sqrt(2 pi) sigma).
  EXPECT_NEAR(*std::max_element(pdf.density.begin(), pdf.density.end()), 1.0 / (std::sqrt(2.0 * kPi) * 0.03), 1.5);
  // At y0 = 0.3 only capsule 1: all its mass in the bin holding 0.25; then push it outside the range.
  const VelocityPdf p3 = velocity_pdf(group_of({r}), Species::All, 0.3, opt);
  const std::size_t k25 = static_cast<std::size_t>((0.25 + 0.3) / 0.004);
  EXPECT_EQ(p3.counts[k25], T);
  for (std::size_t t = 0; t < T; ++t) set_uy(r, t, 1, 0.5);
  const VelocityPdf wide = velocity_pdf(group_of({r}), Species::All, 0.3, opt);
  EXPECT_TRUE(wide.widened);
  EXPECT_GE(wide.edges.back(), 0.5);
  EXPECT_NEAR(wide.edges.front(), -0.3, 1e-15);
  EXPECT_NEAR(std::fmod(wide.edges.back() + 0.3 + 1e-9, 0.004), 1e-9, 1e-9);  // the same lattice of edges
}

// ---------------------------------------------------------------------------------------------------------------
// d(t), f_AB, pinned and pair runs (§5, §10, §11, §12)

TEST(AnalysisDynamics, PinnedCapsulesGiveExactDBarAndMigrationVelocity) {
  // Four pinned capsules at fixed heights (H = 10): d-bar/(H/2) = mean |y - 5| / 5.
  const std::vector<double> ys = {1.5, 3.0, 6.5, 9.0};
  RunSeries r = make_run(10.0, 201, 0.1, {0.2, 0.5, 0.2, 0.5}, {0, 1, 0, 1});
  r.pinned = {1, 1, 1, 1};
  const std::vector<double> us = {0.0123, 0.004, -0.003, -0.02};
  for (std::size_t t = 0; t < 201; ++t)
    for (std::size_t i = 0; i < 4; ++i) {
      set_y(r, t, i, ys[i]);
      set_uy(r, t, i, us[i]);
    }
  const RunGroup g = group_of({r});
  const DBar d = steady_d_bar(g, Species::All, AnalysisOptions{});
  EXPECT_NEAR(d.d.value, (3.5 + 2.0 + 1.5 + 4.0) / 4.0 / 5.0, 1e-14);
  EXPECT_NEAR(d.d.se, 0.0, 1e-14);
  EXPECT_TRUE(d.steady);
  EXPECT_NEAR(steady_d_bar(g, Species::Stiff, AnalysisOptions{}).d.value, (3.5 + 1.5) / 2.0 / 5.0, 1e-14);
  EXPECT_NEAR(steady_d_bar(g, Species::Floppy, AnalysisOptions{}).d.value, (2.0 + 4.0) / 2.0 / 5.0, 1e-14);
  const TimeSeries ts = d_bar_series(g, Species::All);
  ASSERT_EQ(ts.time.size(), 201u);
  EXPECT_NEAR(ts.value[100], 0.55, 1e-14);

  // V^S: the first pinned capsule by default, the mean over the last 5 strain units.
  const MigrationVelocity v0 = isolated_migration_velocity(r);
  EXPECT_EQ(v0.capsule, 0u);
  EXPECT_NEAR(v0.U_y.value, 0.0123, 1e-15);
  EXPECT_NEAR(v0.v_p.value, 0.0123, 1e-15);
  EXPECT_NEAR(v0.y0_over_H, 0.15, 1e-15);
  EXPECT_TRUE(v0.steady);
  EXPECT_NEAR(v0.window.t0, 15.0, 1e-12);
  MigrationOptions mo;
  mo.capsule = 3;  // upper half: v_p = -U_y
  const MigrationVelocity v3 = isolated_migration_velocity(r, mo);
  EXPECT_NEAR(v3.U_y.value, -0.02, 1e-15);
  EXPECT_NEAR(v3.v_p.value, 0.02, 1e-15);

  // A drifting velocity U_y = 0.01 + 1e-3 t: mean over [15, 20] is 0.01 + 0.0175, slope 1e-3 -> not steady.
  RunSeries drift = make_run(10.0, 201, 0.1, {0.2}, {0});
  drift.pinned = {1};
  drift.taylor_D.assign(201, 0.1);
  for (std::size_t t = 0; t < 201; ++t) {
    set_y(drift, t, 0, 2.0);
    set_uy(drift, t, 0, 0.01 + 1e-3 * drift.time[t]);
  }
  const MigrationVelocity vd = isolated_migration_velocity(drift);
  EXPECT_NEAR(vd.U_y.value, 0.0275, 1e-12);
  EXPECT_NEAR(vd.U_rate, 1e-3 / 0.0275, 1e-9);
  EXPECT_NEAR(vd.D_rate, 0.0, 1e-12);
  EXPECT_FALSE(vd.steady);
  mo = MigrationOptions{};
  mo.t0 = 5.0;
  mo.t1 = 10.0;
  EXPECT_NEAR(isolated_migration_velocity(drift, mo).U_y.value, 0.01 + 7.5e-3, 1e-12);
}

TEST(AnalysisDynamics, DBarSeriesAveragesRealizationsAndSteadinessSeesADrift) {
  RunSeries a = make_run(10.0, 2001, 1.0, {0.2, 0.5}, {0, 1});
  RunSeries b = a;
  for (std::size_t t = 0; t < 2001; ++t) {
    set_y(a, t, 0, 1.0);
    set_y(b, t, 0, 3.0);
    set_y(a, t, 1, 5.0 + 1.5e-3 * static_cast<double>(t));  // the floppy capsules drift toward the wall
    set_y(b, t, 1, 5.2 + 1.5e-3 * static_cast<double>(t));
  }
  const RunGroup g = group_of({a, b});
  const TimeSeries s = d_bar_series(g, Species::Stiff);
  EXPECT_NEAR(s.value[7], (4.0 + 2.0) / 2.0 / 5.0, 1e-15);
  const TimeSeries f = d_bar_series(g, Species::Floppy);
  EXPECT_NEAR(f.value[1000], (1.5 + 1.7) / 2.0 / 5.0, 1e-14);
  const DBar df = steady_d_bar(g, Species::Floppy, AnalysisOptions{});
  EXPECT_FALSE(df.steady);
  // Mean d over both runs is (0.1 + 1.5e-3 t) / 5: the halves of [1000, 2000] centre on t = 1250 and 1750.
  EXPECT_NEAR(df.first_half.value, (0.1 + 1.5e-3 * 1249.5) / 5.0, 1e-3);
  EXPECT_NEAR(df.second_half.value, (0.1 + 1.5e-3 * 1750.0) / 5.0, 1e-3);
}

TEST(AnalysisDynamics, TransitionProbabilityCountsCrossingsWithinTheHorizon) {
  // Window [0, 100.5], records every 0.05: one origin (t = 0). H = 10, A: y' < 3.
  const std::size_t T = 2011;
  RunSeries r = make_run(10.0, T, 0.05, {0.2, 0.2, 0.2, 0.2, 0.2}, {0, 0, 0, 0, 0});
  for (std::size_t t = 0; t < T; ++t) {
    const double tt = r.time[t];
    set_y(r, t, 0, tt >= 99.95 - 1e-9 ? 5.0 : 1.0);   // enters B at t0 + 99.95: counts
    set_y(r, t, 1, tt >= 100.05 - 1e-9 ? 5.0 : 1.0);  // enters B at t0 + 100.05: does not
    set_y(r, t, 2, 5.0);                              // starts in B: not an A start
    set_y(r, t, 3, 9.0);                              // upper A throughout
    set_y(r, t, 4, t == 1000 ? 5.0 : 9.5);           // one record in B at t = 50: counts
  }
  AnalysisOptions opt;
  opt.window_start = 0.0;
  opt.window_end = 100.5;
  const TransitionProbability f = transition_probability(group_of({r}), Species::Stiff, opt);
  ASSERT_TRUE(f.f.defined) << f.f.reason;
  EXPECT_EQ(f.origins, 1u);
  EXPECT_EQ(f.starts, 4.0);
  EXPECT_EQ(f.hits, 2.0);
  EXPECT_NEAR(f.f.value, 0.5, 1e-15);

  // A window shorter than the horizon: null with a reason.
  opt.window_end = 99.0;
  const TransitionProbability none = transition_probability(group_of({r}), Species::Stiff, opt);
  EXPECT_FALSE(none.f.defined);
  EXPECT_NE(none.f.reason.find("shorter than the horizon"), std::string::npos);
  // Default window of a 100-strain run: the second half, 50 strain, is too short as well.
  EXPECT_FALSE(transition_probability(group_of({r}), Species::Stiff, AnalysisOptions{}).f.defined);
}

TEST(AnalysisDynamics, TransitionProbabilityPoolsOriginsOfAPeriodicTrajectory) {
  // y in A for (t mod 300) < 150, in B otherwise; window [0, 1000], origins t = 0, 1, ..., 900.
  // From phase p < 150 the capsule enters B after 150 - p <= 100 iff p >= 50: f = hits / starts with
  // starts = 3 x 150 + 1 (phases 0..149 in [0, 900) and t = 900) and hits = 3 x 100.
  const std::size_t T = 2001;
  RunSeries r = make_run(10.0, T, 0.5, {0.5, 0.5}, {1, 1});
  for (std::size_t t = 0; t < T; ++t) {
    const double ph = std::fmod(r.time[t], 300.0);
    set_y(r, t, 0, ph < 150.0 ? 2.0 : 4.0);
    set_y(r, t, 1, ph < 150.0 ? 8.0 : 6.5);  // the same in the upper half
  }
  AnalysisOptions opt;
  opt.window_start = 0.0;
  opt.window_end = 1000.0;
  const TransitionProbability f = transition_probability(group_of({r}), Species::Floppy, opt);
  EXPECT_EQ(f.origins, 901u);
  EXPECT_EQ(f.starts, 2.0 * 451.0);
  EXPECT_EQ(f.hits, 2.0 * 300.0);
  EXPECT_NEAR(f.f.value, 300.0 / 451.0, 1e-15);
  EXPECT_TRUE(std::isfinite(f.f.se));
  EXPECT_GT(f.f.se, 0.0);
  EXPECT_FALSE(transition_probability(group_of({r}), Species::Stiff, opt).f.defined);  // no stiff capsules
}

TEST(AnalysisDynamics, PairCollisionDisplacementAtFinalSeparation) {
  // Capsule 0 is the bottom one. x_top - x_bottom = -10 + 0.5 t reaches +10 at t = 40 (records every 0.07, so
  // the value is interpolated); y_top = 15.25 + 0.01 t, y_bottom = 14.75 - 0.02 t.
  const std::size_t T = 700;
  RunSeries r = make_run(30.0, T, 0.07, {0.5, 0.2}, {1, 0});
  for (std::size_t t = 0; t < T; ++t) {
    const double tt = r.time[t];
    set_x(r, t, 1, 15.0 - 5.0 + 0.25 * tt);
    set_x(r, t, 0, 15.0 + 5.0 - 0.25 * tt);
    set_y(r, t, 1, 15.25 + 0.01 * tt);
    set_uy(r, t, 1, 0.01);
    set_y(r, t, 0, 14.75 - 0.02 * tt);
    set_uy(r, t, 0, -0.02);
  }
  const PairCollision pc = pair_collision(r);
  EXPECT_EQ(pc.top.capsule, 1u);
  EXPECT_EQ(pc.bottom.capsule, 0u);
  EXPECT_DOUBLE_EQ(pc.top.ca, 0.2);
  EXPECT_NEAR(pc.separation[0], -10.0, 1e-14);
  EXPECT_NEAR(pc.crossing_time.value, 40.0, 1e-10);
  EXPECT_NEAR(pc.top.final_displacement.value, 0.4, 1e-10);
  EXPECT_NEAR(pc.bottom.final_displacement.value, 0.8, 1e-10);  // sign-flipped: separating is positive
  EXPECT_NEAR(pc.top.final_speed.value, 0.01, 1e-14);
  EXPECT_NEAR(pc.bottom.final_speed.value, 0.02, 1e-14);
  EXPECT_NEAR(pc.bottom.velocity[10], 0.02, 1e-15);
  EXPECT_NEAR(pc.bottom.displacement[100], 0.02 * r.time[100], 1e-12);
  EXPECT_FALSE(pc.top.settled);  // |U_y| = 0.01 >= 1e-3
  // Stopped before the final separation: undefined with a reason.
  RunSeries shortr = r;
  shortr.time.resize(300);
  shortr.centroid.resize(3 * 300 * 2);
  shortr.velocity.resize(3 * 300 * 2);
  const PairCollision ps = pair_collision(shortr);
  EXPECT_FALSE(ps.top.final_displacement.defined);
  EXPECT_NE(ps.top.final_displacement.reason.find("reaches at most"), std::string::npos);
  EXPECT_THROW(pair_collision(make_run(30.0, 5, 1.0, {0.2}, {0})), InputError);
}

TEST(AnalysisChecks, VolumeDriftFlagsCapsulesBeyondTolerance) {
  RunSeries r = make_run(10.0, 3, 1.0, {0.2, 0.2}, {0, 0});
  r.volume = {4.0, 4.0, 4.04, 3.9, 4.06, 3.95};  // capsule 0: +1.5%, capsule 1: -2.5%
  const VolumeDrift d = volume_drift(r);
  EXPECT_TRUE(d.available);
  EXPECT_NEAR(d.max_relative, 0.025, 1e-15);
  EXPECT_EQ(d.flagged, (std::vector<std::size_t>{1}));
  EXPECT_FALSE(volume_drift(make_run(10.0, 3, 1.0, {0.2}, {0})).available);
}
