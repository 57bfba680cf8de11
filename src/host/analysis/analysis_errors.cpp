// The implementation of analysis_errors.hpp: standard errors of time averages of correlated series.
#include "host/analysis/analysis_errors.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "host/base/printable.hpp"

namespace capsflow::analysis {
namespace {

std::string num(double v) { return format_significant(v, 3); }

double mean_of(const std::vector<double>& x) {
  double s = 0.0;
  for (double v : x) s += v;
  return x.empty() ? kNaN : s / static_cast<double>(x.size());
}

}  // namespace

BlockSweep block_sweep(const std::vector<double>& x, std::size_t min_blocks) {
  BlockSweep res;
  const std::size_t N = x.size();
  if (N < 2 || N < min_blocks) {
    res.se = Estimate::undefined("not estimable: fewer than " + std::to_string(std::max<std::size_t>(min_blocks, 2)) +
                                 " records in the window");
    return res;
  }
  for (std::size_t b = 1; N / b >= 2; b *= 2) {
    BlockLevel L;
    L.block = b;
    L.blocks = N / b;
    std::vector<double> m(L.blocks, 0.0);
    for (std::size_t i = 0; i < L.blocks; ++i) {
      double s = 0.0;
      for (std::size_t j = 0; j < b; ++j) s += x[i * b + j];
      m[i] = s / static_cast<double>(b);
    }
    const double mm = mean_of(m);
    double ss = 0.0;
    for (double v : m) ss += (v - mm) * (v - mm);
    const double n = static_cast<double>(L.blocks);
    L.se = std::sqrt(ss / (n * (n - 1.0)));
    L.se_error = L.se / std::sqrt(2.0 * (n - 1.0));
    res.levels.push_back(L);
    if (L.blocks >= min_blocks) ++res.usable;
  }
  const double se1 = res.levels.front().se;
  if (se1 == 0.0) {  // a constant series: every block mean is the same
    res.optimal = 0;
    res.plateau = true;
    res.se = Estimate::of(0.0, 0.0, "constant series");
    return res;
  }
  double largest = 0.0;
  for (std::size_t k = 0; k < res.usable; ++k) largest = std::max(largest, res.levels[k].se);
  const double n_records = static_cast<double>(N);
  for (std::size_t k = 0; k < res.usable; ++k) {
    const double B = static_cast<double>(res.levels[k].block), r = res.levels[k].se / se1;
    if (B * B * B > 2.0 * n_records * r * r * r * r) {
      res.optimal = static_cast<int>(k);
      break;
    }
  }
  const BlockLevel& last = res.levels[res.usable - 1];
  if (res.optimal < 0) {
    res.lower_bound = largest;
    res.se = Estimate::undefined("not estimable: the block SE still grows at the largest usable block (" +
                                 std::to_string(last.block) + " records, " + std::to_string(last.blocks) +
                                 " blocks) without reaching the optimal block size; the SE is at least " +
                                 num(largest));
    return res;
  }
  const BlockLevel& opt = res.levels[static_cast<std::size_t>(res.optimal)];
  for (std::size_t j = static_cast<std::size_t>(res.optimal) + 1; j < res.usable; ++j) {
    const BlockLevel& L = res.levels[j];
    if (L.se - opt.se > 3.0 * std::hypot(L.se_error, opt.se_error)) {
      res.lower_bound = largest;
      res.se = Estimate::undefined("not estimable: the block SE grows past the optimal block (" + num(opt.se) +
                                   " at " + std::to_string(opt.block) + " records, " + num(L.se) + " at " +
                                   std::to_string(L.block) + "); the SE is at least " + num(largest));
      return res;
    }
  }
  res.plateau = true;
  res.se = Estimate::of(opt.se, opt.se_error);  // se of the Estimate: the SE; its own uncertainty in se_error
  return res;
}

AutocorrelationTime autocorrelation_time(const std::vector<double>& x, double c, double min_length) {
  AutocorrelationTime res;
  const std::size_t N = x.size();
  if (N < 4) {
    res.se = Estimate::undefined("not estimable: fewer than 4 records in the window");
    return res;
  }
  const double m = mean_of(x);
  std::vector<double> d(N);
  for (std::size_t i = 0; i < N; ++i) d[i] = x[i] - m;
  double c0 = 0.0;
  for (double v : d) c0 += v * v;
  c0 /= static_cast<double>(N);
  if (c0 == 0.0) {
    res.tau = 0.5;
    res.se = Estimate::of(0.0, 0.0, "constant series");
    return res;
  }
  double tau = 0.5;
  for (std::size_t M = 1; M < N / 2; ++M) {
    double cm = 0.0;
    for (std::size_t i = 0; i + M < N; ++i) cm += d[i] * d[i + M];
    tau += cm / static_cast<double>(N) / c0;
    if (static_cast<double>(M) >= c * tau) {
      res.window = M;
      break;
    }
  }
  res.tau = tau;
  if (res.window == 0) {
    res.se = Estimate::undefined("not estimable: no window M < N/2 with M >= " + num(c) +
                                 " tau_int(M) (the series is correlated over most of its length)");
    return res;
  }
  const double n = static_cast<double>(N);
  res.tau_error = tau * std::sqrt(2.0 * (2.0 * static_cast<double>(res.window) + 1.0) / n);
  if (!(tau > 0.0)) {
    res.se = Estimate::undefined("not estimable: tau_int = " + num(tau) + " <= 0");
    return res;
  }
  if (n < min_length * tau) {
    res.se = Estimate::undefined("not estimable: " + std::to_string(N) + " records are fewer than " + num(min_length) +
                                 " tau_int (tau_int = " + num(tau) + " records)");
    return res;
  }
  const double se = std::sqrt(2.0 * tau * c0 / n);
  res.se = Estimate::of(se, 0.5 * se * res.tau_error / tau);
  return res;
}

MeanError mean_error(const std::vector<std::vector<double>>& series, const std::vector<double>& spacing) {
  MeanError res;
  const std::size_t R = series.size();
  res.runs = R;
  if (R == 0) {
    res.se = res.block = res.tau = res.seeds = Estimate::undefined("no runs");
    res.rule = "no runs";
    return res;
  }
  const double Rd = static_cast<double>(R);
  bool all_block = true, all_tau = true, lb_ok = true;
  double sb = 0.0, st = 0.0, slb = 0.0, blen = 0.0, tint = 0.0;
  std::string block_why, tau_why;
  std::vector<double> means;
  std::vector<BlockSweep> sweeps;
  for (std::size_t r = 0; r < R; ++r) {
    const std::vector<double>& x = series[r];
    const double h = r < spacing.size() ? spacing[r] : kNaN;
    means.push_back(mean_of(x));
    sweeps.push_back(block_sweep(x));
    const BlockSweep& bs = sweeps.back();
    if (bs.se.defined) {
      sb += bs.se.value * bs.se.value;
      slb += bs.se.value * bs.se.value;
      blen += static_cast<double>(bs.levels[static_cast<std::size_t>(bs.optimal)].block) * h / Rd;
    } else {
      all_block = false;
      if (block_why.empty()) block_why = bs.se.reason;
      if (std::isfinite(bs.lower_bound)) slb += bs.lower_bound * bs.lower_bound;
      else lb_ok = false;
    }
    const AutocorrelationTime ac = autocorrelation_time(x);
    tint += ac.tau * h / Rd;
    if (ac.se.defined) {
      st += ac.se.value * ac.se.value;
    } else {
      all_tau = false;
      if (tau_why.empty()) tau_why = ac.se.reason;
    }
  }
  std::size_t levels = sweeps.front().levels.size(), usable = sweeps.front().usable;
  for (const BlockSweep& bs : sweeps) {
    levels = std::min(levels, bs.levels.size());
    usable = std::min(usable, bs.usable);
  }
  res.sweep_usable = usable;
  for (std::size_t k = 0; k < levels; ++k) {
    double se2 = 0.0, u2 = 0.0, len = 0.0;
    for (std::size_t r = 0; r < R; ++r) {
      const BlockLevel& L = sweeps[r].levels[k];
      se2 += L.se * L.se;
      u2 += L.se_error * L.se_error;
      len += static_cast<double>(L.block) * (r < spacing.size() ? spacing[r] : kNaN) / Rd;
    }
    res.sweep_length.push_back(len);
    res.sweep_se.push_back(std::sqrt(se2) / Rd);
    res.sweep_se_error.push_back(std::sqrt(u2) / Rd);
  }
  const std::string runs_note = R > 1 ? " (in one of the runs)" : "";
  res.block = all_block ? Estimate::of(std::sqrt(sb) / Rd, kNaN) : Estimate::undefined(block_why + runs_note);
  if (all_block) res.block_length = blen;
  if (lb_ok) res.block_lower_bound = std::sqrt(slb) / Rd;
  res.tau = all_tau ? Estimate::of(std::sqrt(st) / Rd, kNaN) : Estimate::undefined(tau_why + runs_note);
  res.tau_int = tint;
  if (R >= 2) {
    const double m = mean_of(means);
    double ss = 0.0;
    for (double v : means) ss += (v - m) * (v - m);
    res.seeds = Estimate::of(std::sqrt(ss / (Rd * (Rd - 1.0))), kNaN);
  } else {
    res.seeds = Estimate::undefined("one realization");
  }

  // Within-run SE: the plateau block SE, or the autocorrelation SE where that is larger.
  Estimate within = res.block;
  std::string within_rule;
  if (res.block.defined) {
    within_rule = "block SE at the plateau (blocks of " + num(res.block_length) + " strain)";
    if (res.tau.defined && res.tau.value > res.block.value) {
      within = res.tau;
      within_rule = "autocorrelation-time SE (tau_int " + num(res.tau_int) + " strain; larger than the block SE " +
                    num(res.block.value) + ")";
    }
  }
  if (R == 1) {
    if (within.defined) {
      res.se = Estimate::of(within.value, kNaN);
      res.rule = within_rule;
    } else {
      res.se = Estimate::undefined("SE " + res.block.reason);
      res.rule = "none: the SE is not estimable";
      res.lower_bound = res.block_lower_bound;
      if (res.tau.defined) res.lower_bound = std::max(res.lower_bound, res.tau.value);
    }
    return res;
  }
  if (within.defined) {
    if (res.seeds.value > within.value) {
      res.se = Estimate::of(res.seeds.value, kNaN);
      res.rule = "across " + std::to_string(R) + " realizations (std of the run means / sqrt(R), larger than the " +
                 within_rule + ")";
    } else {
      res.se = Estimate::of(within.value, kNaN);
      res.rule = within_rule + ", combined over " + std::to_string(R) + " realizations (larger than their spread)";
    }
  } else {
    res.se = Estimate::of(res.seeds.value, kNaN,
                          "from the spread of " + std::to_string(R) + " run means only (" + std::to_string(R - 1) +
                              " degrees of freedom): the within-run SE is " + res.block.reason);
    res.rule = res.se.reason;
  }
  return res;
}

HalvesTest halves_test(const Estimate& first, const Estimate& second) {
  HalvesTest h;
  h.first = first;
  h.second = second;
  if (!first.defined || !second.defined) {
    h.verdict = "not judged: a half of the window has no records";
    return h;
  }
  h.difference = second.value - first.value;
  if (!std::isfinite(first.se) || !std::isfinite(second.se)) {
    h.verdict = "not judged: a half of the window has fewer than 2 blocks";
    return h;
  }
  const double den = std::hypot(first.se, second.se);
  h.z = den > 0.0 ? h.difference / den : (h.difference == 0.0 ? 0.0 : std::copysign(INFINITY, h.difference));
  h.steady = std::abs(h.difference) <= 2.0 * den;
  h.verdict = h.steady ? "steady" : "not steady";
  return h;
}

}  // namespace capsflow::analysis
