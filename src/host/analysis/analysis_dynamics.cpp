// The implementation of analysis_dynamics.hpp: d(t), f_AB, a pinned capsule's migration, pair collisions.
#include "host/analysis/analysis_dynamics.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <tuple>

#include "host/base/errors.hpp"
#include "host/base/printable.hpp"

namespace capsflow::analysis {
namespace {

std::size_t uz(int v) { return static_cast<std::size_t>(v); }

std::string absent(Species s) { return std::string("no ") + species_name(s) + " capsules in this group"; }

std::string num(double v) { return format_significant(v, 6); }

// Time tolerance for comparisons of record times with nominal times (strain).
double time_tol(double t) { return 1e-9 * (1.0 + std::abs(t)); }

// d-bar_X / (H/2) at record t of a run: mean over the capsules in mask of |y - H/2| / (H/2).
double d_record(const RunSeries& run, const std::vector<char>& mask, std::size_t nx, std::size_t t) {
  const double h = 0.5 * run.H;
  double s = 0.0;
  for (std::size_t i = 0; i < run.np; ++i)
    if (mask[i]) s += std::abs(run.y(t, i) - h);
  return s / (static_cast<double>(nx) * h);
}

// Pooled block means of d-bar / (H/2) with nblocks blocks per run (NaN for blocks without records).
std::vector<double> d_block_means(const RunGroup& g, Species s, const AnalysisOptions& opt, int nblocks) {
  const GroupBlocks gb = group_blocks(g, opt, nblocks);
  std::vector<double> sum(uz(gb.total()), 0.0), cnt(uz(gb.total()), 0.0);
  for (std::size_t r = 0; r < g.runs.size(); ++r) {
    const RunSeries& run = g.runs[r];
    const auto mask = species_mask(run, s, g.ca);
    const auto nx = static_cast<std::size_t>(std::count(mask.begin(), mask.end(), 1));
    for (std::size_t t = 0; t < run.records(); ++t) {
      const int b = gb.block[r][t];
      if (b < 0 || nx == 0) continue;
      sum[uz(b)] += d_record(run, mask, nx, t);
      cnt[uz(b)] += 1.0;
    }
  }
  std::vector<double> means(sum.size(), kNaN);
  for (std::size_t b = 0; b < sum.size(); ++b)
    if (cnt[b] > 0.0) means[b] = sum[b] / cnt[b];
  return means;
}

std::size_t finite_count(const std::vector<double>& v) {
  return static_cast<std::size_t>(std::count_if(v.begin(), v.end(), [](double x) { return std::isfinite(x); }));
}

}  // namespace

// ---------------------------------------------------------------------------------------------------------------

TimeSeries d_bar_series(const RunGroup& g, Species s) {
  validate_group(g);
  TimeSeries ts;
  std::size_t T = g.runs.front().records();
  for (const RunSeries& r : g.runs) T = std::min(T, r.records());
  std::vector<std::vector<char>> masks;
  std::vector<std::size_t> nxs;
  for (const RunSeries& r : g.runs) {
    masks.push_back(species_mask(r, s, g.ca));
    nxs.push_back(static_cast<std::size_t>(std::count(masks.back().begin(), masks.back().end(), 1)));
    if (nxs.back() == 0) {
      ts.reason = absent(s);
      return ts;
    }
  }
  const double R = static_cast<double>(g.runs.size());
  ts.time.assign(T, 0.0);
  ts.value.assign(T, 0.0);
  for (std::size_t r = 0; r < g.runs.size(); ++r)
    for (std::size_t t = 0; t < T; ++t) {
      ts.time[t] += g.runs[r].time[t] / R;
      ts.value[t] += d_record(g.runs[r], masks[r], nxs[r], t) / R;
    }
  for (const RunSeries& r : g.runs)
    if (r.records() != T) ts.reason = "realizations have different lengths: the series stops at the shortest";
  return ts;
}

DBar steady_d_bar(const RunGroup& g, Species s, const AnalysisOptions& opt) {
  validate_group(g);
  if (opt.blocks <= 0) throw InputError("analysis: blocks must be positive");
  DBar res;
  for (const RunSeries& r : g.runs) res.windows.push_back(steady_window(r, opt));
  std::size_t nx = 0;
  for (const RunSeries& r : g.runs) nx += species_count(r, s, g.ca);
  if (nx == 0) {
    res.d = res.first_half = res.second_half = Estimate::undefined(absent(s));
    return res;
  }
  double wlen = 0.0;
  for (const Window& w : res.windows) wlen += w.length() / static_cast<double>(res.windows.size());

  const int b = opt.blocks;
  const std::vector<double> nominal = d_block_means(g, s, opt, b);
  res.d = block_average(nominal);
  if (!res.d.defined) {
    res.d.reason = "no records in the steady window";
    res.first_half = res.second_half = res.d;
    return res;
  }

  // The block-length check of §4: halve and double the nominal block length.
  const int counts[3] = {2 * b, b, std::max(b / 2, 1)};
  std::size_t nfin[3] = {0, 0, 0};
  for (int j = 0; j < 3; ++j) {
    const auto means = j == 1 ? nominal : d_block_means(g, s, opt, counts[j]);
    res.block_length.push_back(wlen / counts[j]);
    res.block_se.push_back(block_average(means).se);
    nfin[j] = finite_count(means);
  }
  const double se_nom = res.block_se[1], se_long = res.block_se[2];
  if (std::isfinite(se_nom) && std::isfinite(se_long) && nfin[2] >= 2) {
    // The relative uncertainty of an SE estimated from n blocks is about 1 / sqrt(2 (n - 1)).
    const double u_nom = se_nom / std::sqrt(2.0 * (static_cast<double>(nfin[1]) - 1.0));
    const double u_long = se_long / std::sqrt(2.0 * (static_cast<double>(nfin[2]) - 1.0));
    res.plateau = se_long - se_nom <= 2.0 * std::sqrt(u_nom * u_nom + u_long * u_long);
  }

  // The SE the value carries (issue 35): per-record series of every run's window.
  std::vector<std::vector<double>> series;
  std::vector<double> spacing;
  for (std::size_t r = 0; r < g.runs.size(); ++r) {
    const RunSeries& run = g.runs[r];
    const auto mask = species_mask(run, s, g.ca);
    const auto nr = static_cast<std::size_t>(std::count(mask.begin(), mask.end(), 1));
    std::vector<double> x;
    double first = kNaN, last = kNaN;
    for (std::size_t t = 0; t < run.records(); ++t) {
      if (nr == 0 || run.time[t] < res.windows[r].t0 || run.time[t] > res.windows[r].t1) continue;
      x.push_back(d_record(run, mask, nr, t));
      if (!std::isfinite(first)) first = run.time[t];
      last = run.time[t];
    }
    if (x.empty()) continue;
    spacing.push_back(x.size() > 1 ? (last - first) / static_cast<double>(x.size() - 1) : kNaN);
    series.push_back(std::move(x));
  }
  res.error = mean_error(series, spacing);
  res.se_rule = res.error.rule;
  res.d.se = res.error.se.defined ? res.error.se.value : kNaN;
  res.d.reason = res.error.se.reason;  // a caveat when estimable, why not otherwise

  // Steadiness (§3): the two halves of the window, blocks [0, b/2) and [b - b/2, b) of each run.
  const int half = b / 2;
  if (half >= 1) {
    std::vector<double> first, second;
    for (std::size_t i = 0; i < nominal.size(); ++i) {
      const int j = static_cast<int>(i) % b;
      if (j < half) first.push_back(nominal[i]);
      if (j >= b - half) second.push_back(nominal[i]);
    }
    res.first_half = block_average(first);
    res.second_half = block_average(second);
  }
  res.halves = halves_test(res.first_half, res.second_half);
  res.steady = res.halves.steady;
  return res;
}

// ---------------------------------------------------------------------------------------------------------------

TransitionProbability transition_probability(const RunGroup& g, Species s, const AnalysisOptions& opt) {
  validate_group(g);
  TransitionProbability res;
  if (!(opt.fab_horizon > 0.0) || !(opt.fab_origin_spacing > 0.0) || opt.fab_subwindows <= 0)
    throw InputError("transition_probability: need fab_horizon > 0, fab_origin_spacing > 0, fab_subwindows > 0");
  std::size_t nx = 0;
  for (const RunSeries& r : g.runs) nx += species_count(r, s, g.ca);
  if (nx == 0) {
    res.f = Estimate::undefined(absent(s));
    return res;
  }
  const double horizon = opt.fab_horizon;
  // Per capsule (run r, capsule i) and per time sub-window (run r, sub-window k) sums: the two jackknifes.
  std::vector<double> cap_hits, cap_starts, sub_hits, sub_starts;
  std::size_t capsules_in_a = 0;
  for (std::size_t r = 0; r < g.runs.size(); ++r) {
    const RunSeries& run = g.runs[r];
    const Window w = steady_window(run, opt);
    if (!(w.length() >= horizon)) {
      res.f = Estimate::undefined("the steady window of " + (run.label.empty() ? std::string("a run") : run.label) +
                                  " (" + w.rule + ", " + num(w.length()) + " strain) is shorter than the horizon " +
                                  num(horizon));
      return res;
    }
    // Origin records and their sub-windows: at most fab_subwindows, each spanning at least the horizon of origins.
    const double last = w.t1 - horizon, span = last - w.t0;
    const int nsub = std::max(1, std::min(opt.fab_subwindows, static_cast<int>(std::floor(span / horizon + 1e-9))));
    res.subwindows = std::max(res.subwindows, nsub);
    res.subwindow_length = span / nsub;
    std::vector<std::size_t> origin;
    std::vector<int> sub;
    std::size_t o = 0;
    for (long j = 0;; ++j) {
      const double tau = w.t0 + static_cast<double>(j) * opt.fab_origin_spacing;
      if (tau > last + time_tol(last)) break;
      while (o < run.records() && run.time[o] < tau - time_tol(tau)) ++o;
      if (o >= run.records() || run.time[o] > last + time_tol(last)) break;
      if (!origin.empty() && origin.back() == o) continue;  // records sparser than the origin spacing
      origin.push_back(o);
      const double f = span > 0.0 ? (tau - w.t0) / span * nsub : 0.0;
      sub.push_back(std::min(static_cast<int>(f), nsub - 1));
    }
    res.origins += origin.size();
    const std::size_t sub0 = sub_hits.size();
    sub_hits.resize(sub0 + uz(nsub), 0.0);
    sub_starts.resize(sub0 + uz(nsub), 0.0);
    const auto mask = species_mask(run, s, g.ca);
    const double yB = opt.fab_region * run.H;
    const std::size_t T = run.records();
    std::vector<std::size_t> next_b(T + 1, T);  // first record >= t in B (T: none)
    for (std::size_t i = 0; i < run.np; ++i) {
      if (!mask[i]) continue;
      for (std::size_t t = T; t-- > 0;) next_b[t] = fold_y(run.y(t, i), run.H) >= yB ? t : next_b[t + 1];
      double h_i = 0.0, s_i = 0.0, crossings = 0.0;
      for (std::size_t k = 0; k < origin.size(); ++k) {
        const std::size_t t0 = origin[k];
        if (fold_y(run.y(t0, i), run.H) >= yB) continue;  // starts in B
        const std::size_t blk = sub0 + uz(sub[k]);
        sub_starts[blk] += 1.0;
        s_i += 1.0;
        const std::size_t nb = next_b[t0 + 1];
        const double tend = run.time[t0] + horizon;
        if (nb < T && run.time[nb] <= tend + time_tol(tend)) {
          sub_hits[blk] += 1.0;
          h_i += 1.0;
        }
      }
      // Distinct A -> B crossings inside the window: records in B whose previous record (also in the window) is in A.
      for (std::size_t t = 1; t < T; ++t)
        if (run.time[t - 1] >= w.t0 && run.time[t] <= w.t1 && fold_y(run.y(t - 1, i), run.H) < yB &&
            fold_y(run.y(t, i), run.H) >= yB)
          crossings += 1.0;
      res.crossings += crossings;
      if (crossings > 0.0) ++res.capsules_crossing;
      if (s_i > 0.0) ++capsules_in_a;
      cap_hits.push_back(h_i);
      cap_starts.push_back(s_i);
    }
  }
  for (std::size_t b = 0; b < sub_hits.size(); ++b) {
    res.hits += sub_hits[b];
    res.starts += sub_starts[b];
  }
  res.capsules = capsules_in_a;
  if (res.starts == 0.0) {
    res.f = Estimate::undefined(std::string("no ") + species_name(s) + " capsule in region A at any origin");
    return res;
  }
  const double f = res.hits / res.starts;
  if (res.hits == 0.0) {
    res.f = Estimate::of(0.0, kNaN, "no A -> B transition within the horizon: no error estimate");
    res.se_rule = res.f.reason;
    return res;
  }
  res.se_capsules = jackknife_ratio(cap_hits, cap_starts);
  res.se_time = jackknife_ratio(sub_hits, sub_starts);
  const double sc = res.se_capsules.se, st = res.se_time.se;
  const std::string cap_rule = "jackknife over the " + std::to_string(capsules_in_a) + " capsules that start in A";
  const std::string time_rule = "jackknife over " + std::to_string(sub_hits.size()) + " sub-windows of " +
                                num(res.subwindow_length) + " strain of origins (>= the horizon)";
  if (std::isfinite(sc) && std::isfinite(st)) {
    res.f = Estimate::of(f, std::max(sc, st));
    res.se_rule = "the larger of the " + cap_rule + " (" + num(sc) + ") and the " + time_rule + " (" + num(st) + ")";
  } else if (std::isfinite(sc)) {
    res.f = Estimate::of(f, sc, "one time sub-window of at least the horizon: the capsule jackknife alone");
    res.se_rule = cap_rule + " (one sub-window of at least the horizon: no time jackknife)";
  } else {
    res.f = Estimate::of(f, kNaN, "fewer than 2 capsules start in A and one sub-window: no error estimate");
    res.se_rule = res.f.reason;
  }
  if (res.capsules_crossing < 2 && std::isfinite(res.f.se))
    res.f.reason = "rests on the crossings of " + std::to_string(res.capsules_crossing) +
                   " capsule(s): the SE is a rough guide";
  return res;
}

// ---------------------------------------------------------------------------------------------------------------

MigrationVelocity isolated_migration_velocity(const RunSeries& run, const MigrationOptions& opt) {
  validate(run);
  if (run.np == 0 || run.records() == 0) throw InputError("isolated_migration_velocity: the run has no records");
  MigrationVelocity mv;
  if (opt.capsule >= 0) {
    if (static_cast<std::size_t>(opt.capsule) >= run.np)
      throw InputError("isolated_migration_velocity: capsule " + std::to_string(opt.capsule) + " out of range");
    mv.capsule = static_cast<std::size_t>(opt.capsule);
  } else {
    const auto it = std::find(run.pinned.begin(), run.pinned.end(), 1);
    mv.capsule = it == run.pinned.end() ? 0 : static_cast<std::size_t>(it - run.pinned.begin());
  }
  const std::size_t i = mv.capsule;
  mv.ca = run.ca[i];
  const double first = run.time.front(), last = run.time.back();
  if (std::isfinite(opt.t0) && std::isfinite(opt.t1)) {
    mv.window.t0 = std::max(opt.t0, first);
    mv.window.t1 = std::min(opt.t1, last);
    mv.window.rule = "sub-window [" + num(opt.t0) + ", " + num(opt.t1) + "]";
  } else {
    mv.window.t0 = std::max(last - opt.average_last, first);
    mv.window.t1 = last;
    mv.window.rule = "last " + num(opt.average_last) + " strain units (docs/analysis.md §10)";
  }
  // Means and least-squares slopes over the records in the sub-window.
  double n = 0.0, st = 0.0, su = 0.0, sy = 0.0, sd = 0.0;
  for (std::size_t t = 0; t < run.records(); ++t) {
    if (run.time[t] < mv.window.t0 || run.time[t] > mv.window.t1) continue;
    n += 1.0;
    st += run.time[t];
    su += run.uy(t, i);
    sy += run.y(t, i);
    if (!run.taylor_D.empty()) sd += run.taylor_D[t * run.np + i];
  }
  if (n == 0.0) {
    mv.U_y = mv.v_p = Estimate::undefined("no records in " + mv.window.rule);
    return mv;
  }
  const double tm = st / n, um = su / n, dm = sd / n;
  mv.y0 = sy / n;
  mv.y0_over_H = mv.y0 / run.H;
  double stt = 0.0, stu = 0.0, std_ = 0.0;
  for (std::size_t t = 0; t < run.records(); ++t) {
    if (run.time[t] < mv.window.t0 || run.time[t] > mv.window.t1) continue;
    const double dt = run.time[t] - tm;
    stt += dt * dt;
    stu += dt * (run.uy(t, i) - um);
    if (!run.taylor_D.empty()) std_ += dt * (run.taylor_D[t * run.np + i] - dm);
  }
  if (stt > 0.0) {
    mv.U_rate = std::abs(stu / stt) / std::abs(um);
    if (!run.taylor_D.empty()) mv.D_rate = std::abs(std_ / stt) / std::abs(dm);
  }
  mv.steady = mv.U_rate < opt.steady_rate && (run.taylor_D.empty() || mv.D_rate < opt.steady_rate);
  const std::string note = mv.steady ? std::string() : "not steady: relative rate of change above " + num(opt.steady_rate) + " per strain (extend the run)";
  mv.U_y = Estimate::of(um, kNaN, note);
  mv.v_p = Estimate::of(fold_velocity(mv.y0, um, run.H), kNaN, note);
  return mv;
}

// ---------------------------------------------------------------------------------------------------------------

PairCollision pair_collision(const RunSeries& run, double final_separation, double speed_tolerance) {
  validate(run);
  if (run.np != 2) throw InputError("pair_collision: needs a run with 2 capsules, not " + std::to_string(run.np));
  if (run.records() == 0) throw InputError("pair_collision: the run has no records");
  if (run.y(0, 0) == run.y(0, 1)) throw InputError("pair_collision: both capsules start at the same height");
  PairCollision pc;
  const std::size_t top = run.y(0, 0) > run.y(0, 1) ? 0 : 1, bottom = 1 - top;
  const std::size_t T = run.records();
  pc.time.resize(T);
  pc.separation.resize(T);
  for (std::size_t t = 0; t < T; ++t) {
    pc.time[t] = run.time[t] - run.time[0];
    pc.separation[t] = run.x(t, top) - run.x(t, bottom);
  }
  for (auto [track, idx, sign] : {std::tuple{&pc.top, top, 1.0}, std::tuple{&pc.bottom, bottom, -1.0}}) {
    track->capsule = idx;
    track->ca = run.ca[idx];
    track->sign = sign;
    track->y_initial = run.y(0, idx);
    track->displacement.resize(T);
    track->velocity.resize(T);
    for (std::size_t t = 0; t < T; ++t) {
      track->displacement[t] = sign * (run.y(t, idx) - track->y_initial);
      track->velocity[t] = sign * run.uy(t, idx);
    }
  }
  // First upward crossing of the final separation.
  std::string why;
  std::size_t k = 0;
  if (pc.separation[0] >= final_separation) {
    why = "x_top - x_bottom starts at " + num(pc.separation[0]) + ", at or beyond " + num(final_separation);
  } else {
    for (k = 1; k < T && pc.separation[k] < final_separation; ++k) {
    }
    if (k == T) {
      const double mx = *std::max_element(pc.separation.begin(), pc.separation.end());
      why = "x_top - x_bottom reaches at most " + num(mx) + " < " + num(final_separation) + " (run longer)";
    }
  }
  if (!why.empty()) {
    pc.crossing_time = pc.top.final_displacement = pc.top.final_speed = pc.bottom.final_displacement =
        pc.bottom.final_speed = Estimate::undefined(why);
    return pc;
  }
  const double f = (final_separation - pc.separation[k - 1]) / (pc.separation[k] - pc.separation[k - 1]);
  const auto lerp = [&](const std::vector<double>& v) { return v[k - 1] + f * (v[k] - v[k - 1]); };
  pc.crossing_time = Estimate::of(lerp(pc.time), kNaN);
  for (PairTrack* track : {&pc.top, &pc.bottom}) {
    track->final_displacement = Estimate::of(lerp(track->displacement), kNaN);
    const double u = std::abs(lerp(track->velocity));
    track->settled = u < speed_tolerance;
    track->final_speed = Estimate::of(u, kNaN, track->settled ? "" : "|U_y| >= " + num(speed_tolerance) + " there");
  }
  return pc;
}

}  // namespace capsflow::analysis
