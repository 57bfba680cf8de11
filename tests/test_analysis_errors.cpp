// Errors of correlated series (issue 35; src/host/analysis/analysis_errors.hpp, docs/analysis.md "Errors of
// correlated series"): every expected value from theory, never from the library's output.
//   - AR(1) series x_t = rho x_{t-1} + e_t: tau_int = (1 + rho) / (2 (1 - rho)) and the exact variance of the mean
//     of N records, sigma_x^2 / N [(1 + rho)/(1 - rho) - 2 rho (1 - rho^N) / (N (1 - rho)^2)];
//   - a linear drift: the halves test's z of a noise-free ramp is 5 (5 blocks per half), and the block SE grows
//     without a plateau;
//   - f_AB of capsules that either cross at every origin or never (Bernoulli(p) per capsule): the capsule jackknife
//     is sqrt(p^ (1 - p^) / (n - 1)) exactly, E[SE^2] = p (1 - p) / n and Var f^ = p (1 - p) / n.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "host/analysis/analysis.hpp"
#include "host/analysis/analysis_dynamics.hpp"
#include "host/analysis/analysis_errors.hpp"

using namespace capsflow::analysis;

namespace {

std::vector<double> ar1(double rho, std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> e(0.0, 1.0);
  std::vector<double> x(n);
  x[0] = e(rng) / std::sqrt(1.0 - rho * rho);  // stationary start
  for (std::size_t t = 1; t < n; ++t) x[t] = rho * x[t - 1] + e(rng);
  return x;
}

// Exact SE of the mean of N records of a stationary AR(1) with unit innovations.
double ar1_se(double rho, std::size_t n) {
  const double N = static_cast<double>(n), var_x = 1.0 / (1.0 - rho * rho);
  const double f = (1.0 + rho) / (1.0 - rho) - 2.0 * rho * (1.0 - std::pow(rho, N)) / (N * (1.0 - rho) * (1.0 - rho));
  return std::sqrt(var_x / N * f);
}

// One capsule whose d/(H/2) follows d[t]: y = H/2 - (H/2) d (H = 10), records every dt from 0.
RunSeries d_run(const std::vector<double>& d, double dt) {
  RunSeries r;
  r.label = "synthetic";
  r.H = r.Lx = r.Lz = 10.0;
  r.np = 1;
  r.ca = {0.2};
  r.species = {0};
  for (std::size_t t = 0; t < d.size(); ++t) {
    r.time.push_back(static_cast<double>(t) * dt);
    r.centroid.insert(r.centroid.end(), {0.0, 5.0 - 5.0 * d[t], 0.0});
    r.velocity.insert(r.velocity.end(), {0.0, 0.0, 0.0});
  }
  return r;
}

RunGroup group_of(std::vector<RunSeries> runs) {
  RunGroup g;
  g.key = composition_key(runs.front());
  g.ca = {0.2, 0.5};
  g.runs = std::move(runs);
  return g;
}

}  // namespace

TEST(AnalysisErrors, BlockPlateauAndAutocorrelationTimeOfAnAr1SeriesGiveTheExactSe) {
  const double rho = 0.9, tau = (1.0 + rho) / (2.0 * (1.0 - rho));  // 9.5 records
  const std::size_t N = std::size_t{1} << 17;
  const double exact = ar1_se(rho, N);
  double se2_block = 0.0, se2_tau = 0.0, tau_sum = 0.0;
  const int R = 10;
  for (int r = 0; r < R; ++r) {
    const std::vector<double> x = ar1(rho, N, 1000 + static_cast<std::uint64_t>(r));
    const BlockSweep bs = block_sweep(x);
    ASSERT_TRUE(bs.plateau) << bs.se.reason;
    ASSERT_TRUE(bs.se.defined);
    // The optimal block of Lee et al.: B^3 > 2 N (2 tau)^2 gives B = 512 here (n = 256 blocks, SE uncertain by 4.4 %).
    EXPECT_EQ(bs.levels[static_cast<std::size_t>(bs.optimal)].block, 512u);
    EXPECT_NEAR(bs.se.value / exact, 1.0, 0.15) << "series " << r;
    se2_block += bs.se.value * bs.se.value / R;
    // The records' own SE ignores the correlation: smaller by sqrt(2 tau) = 4.36.
    EXPECT_NEAR(bs.levels.front().se / exact, 1.0 / std::sqrt(2.0 * tau), 0.02);

    const AutocorrelationTime ac = autocorrelation_time(x);
    ASSERT_TRUE(ac.se.defined) << ac.se.reason;
    EXPECT_NEAR(ac.tau / tau, 1.0, 0.15) << "series " << r;  // Madras-Sokal: tau uncertain by ~4 %
    EXPECT_GE(static_cast<double>(ac.window), 6.0 * ac.tau);
    EXPECT_NEAR(ac.se.value / exact, 1.0, 0.1) << "series " << r;
    se2_tau += ac.se.value * ac.se.value / R;
    tau_sum += ac.tau / R;
  }
  // Averaged over 10 series the estimators are unbiased to their remaining bias (block: ~1 %, window: < 1 %).
  EXPECT_NEAR(std::sqrt(se2_block) / exact, 1.0, 0.05);
  EXPECT_NEAR(std::sqrt(se2_tau) / exact, 1.0, 0.04);
  EXPECT_NEAR(tau_sum / tau, 1.0, 0.05);
}

TEST(AnalysisErrors, UncorrelatedRecordsHaveTauOneHalfAndTheTextbookSe) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> e(0.0, 2.0);
  std::vector<double> x(20000);
  for (double& v : x) v = e(rng);
  const double se = 2.0 / std::sqrt(20000.0);
  const BlockSweep bs = block_sweep(x);
  ASSERT_TRUE(bs.se.defined) << bs.se.reason;
  EXPECT_NEAR(bs.se.value / se, 1.0, 0.2);  // the optimal block (B^3 > 2 N) holds 32 records: 625 blocks
  const AutocorrelationTime ac = autocorrelation_time(x);
  ASSERT_TRUE(ac.se.defined);
  EXPECT_NEAR(ac.tau, 0.5, 0.1);
  EXPECT_NEAR(ac.se.value / se, 1.0, 0.1);
  // A constant series: SE 0, not "not estimable".
  const BlockSweep c = block_sweep(std::vector<double>(100, 3.0));
  EXPECT_TRUE(c.se.defined);
  EXPECT_EQ(c.se.value, 0.0);
}

TEST(AnalysisErrors, LongCorrelationsAreNotEstimableAndGiveALowerBound) {
  // rho = 0.999: tau_int = 999.5 records in 20000 records. Neither estimator can give an SE: the block SE still
  // grows at the largest usable block (1024 records, 19 blocks), and the series is 20 tau long, not 100.
  const double rho = 0.999;
  const std::vector<double> x = ar1(rho, 20000, 3);
  const BlockSweep bs = block_sweep(x);
  EXPECT_FALSE(bs.se.defined);
  EXPECT_FALSE(bs.plateau);
  EXPECT_NE(bs.se.reason.find("not estimable"), std::string::npos) << bs.se.reason;
  ASSERT_TRUE(std::isfinite(bs.lower_bound));
  EXPECT_LT(bs.lower_bound, ar1_se(rho, 20000));  // a lower bound indeed (the exact SE is larger)
  const AutocorrelationTime ac = autocorrelation_time(x);
  EXPECT_FALSE(ac.se.defined);
  EXPECT_NE(ac.se.reason.find("not estimable"), std::string::npos) << ac.se.reason;
}

TEST(AnalysisErrors, ALinearDriftIsNotSteadyByTheHalvesTestAndHasNoEstimableSe) {
  // d(t) = 0.4 - 1e-4 t over [0, 1000] (records every 0.5), window [0, 1000]: ten blocks of 100 strain. Noise-free,
  // the block means step by delta = 0.01: each half's 5 means have sample variance 10 delta^2 / 4, so SE
  // delta / sqrt(2); the halves differ by 5 delta, so z = 5 delta / sqrt(2 delta^2 / 2) = 5.
  std::vector<double> d(2001);
  for (std::size_t t = 0; t < d.size(); ++t) d[t] = 0.4 - 1e-4 * 0.5 * static_cast<double>(t);
  AnalysisOptions opt;
  opt.window_start = 0.0;
  opt.window_end = 1000.0;
  const DBar ramp = steady_d_bar(group_of({d_run(d, 0.5)}), Species::All, opt);
  EXPECT_EQ(ramp.halves.verdict, "not steady");
  EXPECT_FALSE(ramp.steady);
  EXPECT_NEAR(ramp.halves.difference, -0.05, 2e-4);
  EXPECT_NEAR(ramp.halves.z, -5.0, 0.01);
  EXPECT_TRUE(ramp.d.defined);
  EXPECT_TRUE(std::isnan(ramp.d.se)) << "a drift has no SE, not a small one";
  EXPECT_NE(ramp.d.reason.find("not estimable"), std::string::npos) << ramp.d.reason;
  EXPECT_GT(ramp.error.lower_bound, 0.0);

  // The same drift under white noise of SD 0.02: still not steady (z ~ -5), and still no SE.
  std::mt19937_64 rng(5);
  std::normal_distribution<double> e(0.0, 0.02);
  std::vector<double> noisy = d, flat(d.size());
  for (std::size_t t = 0; t < d.size(); ++t) {
    noisy[t] += e(rng);
    flat[t] = 0.3 + e(rng);
  }
  const DBar nd = steady_d_bar(group_of({d_run(noisy, 0.5)}), Species::All, opt);
  EXPECT_EQ(nd.halves.verdict, "not steady");
  EXPECT_LT(nd.halves.z, -3.0);
  EXPECT_TRUE(std::isnan(nd.d.se));

  // Without the drift: steady, and the SE is the textbook one of 2001 independent records.
  const DBar fd = steady_d_bar(group_of({d_run(flat, 0.5)}), Species::All, opt);
  EXPECT_EQ(fd.halves.verdict, "steady");
  ASSERT_TRUE(std::isfinite(fd.d.se)) << fd.d.reason;
  EXPECT_NEAR(fd.d.se / (0.02 / std::sqrt(2001.0)), 1.0, 0.25);
  EXPECT_NEAR(fd.d.value, 0.3, 4.0 * 0.02 / std::sqrt(2001.0));
}

TEST(AnalysisErrors, SeveralRealizationsCarryTheSpreadOfTheirMeans) {
  // Four runs of white noise (SD 0.001) about 0.30, 0.31, 0.32, 0.33: the run means' spread, std / sqrt(4) =
  // 0.0129099 / 2, dominates the within-run SE (~0.001 / sqrt(2001) / 2).
  std::mt19937_64 rng(9);
  std::normal_distribution<double> e(0.0, 0.001);
  std::vector<RunSeries> runs;
  for (int r = 0; r < 4; ++r) {
    std::vector<double> d(2001);
    for (double& v : d) v = 0.30 + 0.01 * r + e(rng);
    runs.push_back(d_run(d, 0.5));
  }
  AnalysisOptions opt;
  opt.window_start = 0.0;
  opt.window_end = 1000.0;
  const DBar g = steady_d_bar(group_of(runs), Species::All, opt);
  const double spread = std::sqrt((0.015 * 0.015 + 0.005 * 0.005) * 2.0 / 3.0) / 2.0;
  ASSERT_TRUE(std::isfinite(g.d.se));
  EXPECT_NEAR(g.d.se / spread, 1.0, 0.01);
  EXPECT_NE(g.se_rule.find("across 4 realizations"), std::string::npos) << g.se_rule;
  ASSERT_TRUE(g.error.block.defined);
  EXPECT_NEAR(g.error.block.value / (0.001 / std::sqrt(2001.0) / 2.0), 1.0, 0.25);
}

namespace {

// n capsules over [0, 300] (records every 0.5, H = 10, A: y' < 3). A crossing capsule sits at y = 1 except one
// record in B (y = 5) at t = 20.5 + 50 k: every origin (integers 0..200) sees B within 50 < 100, and no origin is in
// B. The others stay at y = 1.
RunSeries bernoulli_run(const std::vector<char>& crosses) {
  RunSeries r;
  r.label = "synthetic";
  r.H = r.Lx = r.Lz = 10.0;
  r.np = crosses.size();
  r.ca.assign(r.np, 0.2);
  r.species.assign(r.np, 0);
  const std::size_t T = 601;
  for (std::size_t t = 0; t < T; ++t) {
    const double tt = 0.5 * static_cast<double>(t);
    r.time.push_back(tt);
    const bool visit = std::fmod(tt - 20.5, 50.0) == 0.0 && tt >= 20.5;
    for (std::size_t i = 0; i < r.np; ++i) {
      r.centroid.insert(r.centroid.end(), {0.0, crosses[i] && visit ? 5.0 : 1.0, 0.0});
      r.velocity.insert(r.velocity.end(), {0.0, 0.0, 0.0});
    }
  }
  return r;
}

}  // namespace

TEST(AnalysisErrors, TransitionProbabilityErrorComesFromIndependentCapsules) {
  AnalysisOptions opt;
  opt.window_start = 0.0;
  opt.window_end = 300.0;
  const std::size_t n = 40;
  std::vector<char> twelve(n, 0);
  for (std::size_t i = 0; i < 12; ++i) twelve[3 * i] = 1;
  const TransitionProbability f = transition_probability(group_of({bernoulli_run(twelve)}), Species::Stiff, opt);
  ASSERT_TRUE(f.f.defined) << f.f.reason;
  EXPECT_EQ(f.origins, 201u);
  EXPECT_DOUBLE_EQ(f.f.value, 12.0 / 40.0);
  EXPECT_EQ(f.capsules, 40u);
  EXPECT_EQ(f.capsules_crossing, 12u);
  EXPECT_EQ(f.crossings, 12.0 * 6.0);  // visits at 20.5, 70.5, ..., 270.5
  // Origin span 200 under a horizon of 100: two sub-windows of 100 strain, each with the same ratio.
  EXPECT_EQ(f.subwindows, 2);
  EXPECT_DOUBLE_EQ(f.subwindow_length, 100.0);
  EXPECT_NEAR(f.se_time.se, 0.0, 1e-15);
  // Delete-one-capsule jackknife of a mean of 0/1 values with equal weights: sqrt(p (1 - p) / (n - 1)).
  const double p = 0.3;
  EXPECT_NEAR(f.se_capsules.se, std::sqrt(p * (1.0 - p) / (n - 1.0)), 1e-12);
  EXPECT_NEAR(f.f.se, std::sqrt(p * (1.0 - p) / (n - 1.0)), 1e-12);

  // Over realizations with each capsule crossing with probability 0.3: E[SE^2] = p (1 - p) / n = Var f^.
  std::mt19937_64 rng(21);
  std::bernoulli_distribution coin(p);
  const int R = 300;
  double m = 0.0, m2 = 0.0, se2 = 0.0;
  for (int r = 0; r < R; ++r) {
    std::vector<char> c(n);
    for (char& v : c) v = coin(rng) ? 1 : 0;
    const TransitionProbability fr = transition_probability(group_of({bernoulli_run(c)}), Species::Stiff, opt);
    ASSERT_TRUE(fr.f.defined);
    const double v = fr.f.value;
    m += v / R;
    m2 += v * v / R;
    if (std::isfinite(fr.f.se)) se2 += fr.f.se * fr.f.se / R;  // (all-zero realizations have no SE: p^n ~ 0)
  }
  const double var_theory = p * (1.0 - p) / static_cast<double>(n);
  EXPECT_NEAR(m, p, 4.0 * std::sqrt(var_theory / R));
  EXPECT_NEAR(se2 / var_theory, 1.0, 0.1);                            // relative SD of the mean ~2 %
  EXPECT_NEAR((m2 - m * m) * R / (R - 1.0) / var_theory, 1.0, 0.25);  // relative SD ~8 %

  // A window whose origins span less than two horizons has one sub-window: no time jackknife, the capsules' alone.
  opt.window_end = 250.0;
  const TransitionProbability one = transition_probability(group_of({bernoulli_run(twelve)}), Species::Stiff, opt);
  EXPECT_EQ(one.subwindows, 1);
  EXPECT_TRUE(std::isnan(one.se_time.se));
  EXPECT_NEAR(one.f.se, one.se_capsules.se, 0.0);
  // No crossing at all: f = 0 with no SE, and the reason.
  const TransitionProbability none =
      transition_probability(group_of({bernoulli_run(std::vector<char>(n, 0))}), Species::Stiff, opt);
  ASSERT_TRUE(none.f.defined);
  EXPECT_EQ(none.f.value, 0.0);
  EXPECT_TRUE(std::isnan(none.f.se));
  EXPECT_FALSE(none.f.reason.empty());
}
