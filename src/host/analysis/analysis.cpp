// The implementation of analysis.hpp: the analysis of capsflow runs for the segregation study (issue 9).
#include "host/analysis/analysis.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>
#include <utility>

#include "host/base/errors.hpp"

namespace capsflow::analysis {
namespace {

bool same_value(double a, double b, double rel = 1e-9) {
  return std::abs(a - b) <= rel * std::max(std::abs(a), std::abs(b));
}

std::string fmt(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

std::string run_name(const RunSeries& run) { return run.label.empty() ? std::string("run") : "run '" + run.label + "'"; }

void require_size(const RunSeries& run, const char* what, std::size_t have, std::size_t want) {
  if (have != want)
    throw InputError(run_name(run) + ": " + what + " has " + std::to_string(have) + " values, expected " +
                     std::to_string(want));
}

}  // namespace

// ---------------------------------------------------------------------------------------------------------------

void validate(const RunSeries& run) {
  if (!(run.H > 0.0) || !(run.Lx > 0.0) || !(run.Lz > 0.0))
    throw InputError(run_name(run) + ": H, Lx and Lz must be positive");
  const std::size_t T = run.records(), np = run.np;
  require_size(run, "centroid", run.centroid.size(), 3 * T * np);
  require_size(run, "velocity", run.velocity.size(), 3 * T * np);
  if (!run.volume.empty()) require_size(run, "volume", run.volume.size(), T * np);
  if (!run.taylor_D.empty()) require_size(run, "taylor_D", run.taylor_D.size(), T * np);
  require_size(run, "species", run.species.size(), np);
  require_size(run, "ca", run.ca.size(), np);
  if (!run.pinned.empty()) require_size(run, "pinned", run.pinned.size(), np);
  for (std::size_t t = 1; t < T; ++t)
    if (!(run.time[t] > run.time[t - 1]))
      throw InputError(run_name(run) + ": time is not increasing at record " + std::to_string(t));
  for (int s : run.species)
    if (s < 0) throw InputError(run_name(run) + ": negative species index");
  if (!run.slab_volume.empty() || run.slab_bins != 0) {
    if (run.slab_bins <= 0 || run.slab_species <= 0)
      throw InputError(run_name(run) + ": slab_volume needs positive slab_bins and slab_species");
    require_size(run, "slab_volume", run.slab_volume.size(),
                 T * static_cast<std::size_t>(run.slab_species) * static_cast<std::size_t>(run.slab_bins));
    for (int s : run.species)
      if (s >= run.slab_species)
        throw InputError(run_name(run) + ": species index " + std::to_string(s) + " has no slab_volume slot");
  }
}

Estimate Estimate::of(double value, double se, std::string note) {
  Estimate e;
  e.value = value;
  e.se = se;
  e.defined = true;
  e.reason = std::move(note);
  return e;
}

Estimate Estimate::undefined(std::string why) {
  Estimate e;
  e.reason = std::move(why);
  return e;
}

bool Profile::any_defined() const { return std::any_of(defined.begin(), defined.end(), [](char c) { return c != 0; }); }

// ---------------------------------------------------------------------------------------------------------------

const char* species_name(Species s) {
  switch (s) {
    case Species::Stiff:
      return "stiff";
    case Species::Floppy:
      return "floppy";
    case Species::All:
      return "all";
  }
  return "?";
}

SpeciesCa identify_species(const std::vector<RunSeries>& runs) {
  std::vector<double> distinct;
  for (const RunSeries& r : runs)
    for (double c : r.ca)
      if (std::none_of(distinct.begin(), distinct.end(), [&](double d) { return same_value(c, d); }))
        distinct.push_back(c);
  std::sort(distinct.begin(), distinct.end());
  if (distinct.size() != 2) {
    std::string list;
    for (double d : distinct) list += (list.empty() ? "" : ", ") + fmt(d);
    throw InputError("identify_species: expected exactly two capillary numbers over the runs, found " +
                     std::to_string(distinct.size()) + (list.empty() ? "" : " (" + list + ")") +
                     "; stiff and floppy must then be given explicitly");
  }
  return {distinct[0], distinct[1]};
}

bool belongs(double ca, Species s, const SpeciesCa& key) {
  const bool stiff = same_value(ca, key.stiff), floppy = same_value(ca, key.floppy);
  if (!stiff && !floppy)
    throw InputError("capsule with Ca = " + fmt(ca) + " is neither stiff (Ca = " + fmt(key.stiff) +
                     ") nor floppy (Ca = " + fmt(key.floppy) + ")");
  switch (s) {
    case Species::Stiff:
      return stiff;
    case Species::Floppy:
      return floppy && !stiff;
    case Species::All:
      return true;
  }
  return false;
}

std::vector<char> species_mask(const RunSeries& run, Species s, const SpeciesCa& key) {
  std::vector<char> m(run.np, 0);
  for (std::size_t i = 0; i < run.np; ++i) m[i] = belongs(run.ca[i], s, key) ? 1 : 0;
  return m;
}

std::size_t species_count(const RunSeries& run, Species s, const SpeciesCa& key) {
  const auto m = species_mask(run, s, key);
  return static_cast<std::size_t>(std::count(m.begin(), m.end(), 1));
}

// ---------------------------------------------------------------------------------------------------------------

std::string composition_key(const RunSeries& run) {
  std::string key = "H=" + fmt(run.H) + " Lx=" + fmt(run.Lx) + " Lz=" + fmt(run.Lz) + " Np=" + std::to_string(run.np);
  std::vector<std::pair<double, int>> counts;  // (Ca, count), sorted by Ca
  for (double c : run.ca) {
    auto it = std::find_if(counts.begin(), counts.end(), [&](const auto& p) { return same_value(p.first, c); });
    if (it == counts.end())
      counts.emplace_back(c, 1);
    else
      ++it->second;
  }
  std::sort(counts.begin(), counts.end());
  for (const auto& [c, n] : counts) key += " Ca=" + fmt(c) + "x" + std::to_string(n);
  for (std::size_t i = 0; i < run.pinned.size(); ++i)
    if (run.pinned[i] && run.records() > 0) key += " pinned y=" + fmt(run.y(0, i));
  return key;
}

std::vector<RunGroup> group_runs(std::vector<RunSeries> runs, const SpeciesCa& ca) {
  std::vector<RunGroup> groups;
  for (RunSeries& r : runs) {
    validate(r);
    const std::string key = composition_key(r);
    auto it = std::find_if(groups.begin(), groups.end(), [&](const RunGroup& g) { return g.key == key; });
    if (it == groups.end()) {
      groups.push_back(RunGroup{key, ca, {}});
      it = groups.end() - 1;
    }
    it->runs.push_back(std::move(r));
  }
  return groups;
}

void validate_group(const RunGroup& group) {
  if (group.runs.empty()) throw InputError("analysis: group '" + group.key + "' has no runs");
  const RunSeries& a = group.runs.front();
  for (const RunSeries& r : group.runs) {
    validate(r);
    if (!same_value(r.H, a.H) || !same_value(r.Lx, a.Lx) || !same_value(r.Lz, a.Lz))
      throw InputError("analysis: " + run_name(r) + " has a different box from " + run_name(a) + " in one group");
  }
}

double floppy_fraction(const RunGroup& group) {
  std::size_t nf = 0, n = 0;
  bool sized = false;
  double vf = 0.0, v = 0.0;  // with mixed sizes: the floppy share of the capsules' nominal volume a^3
  for (const RunSeries& r : group.runs) {
    nf += species_count(r, Species::Floppy, group.ca);
    n += r.np;
    if (r.capsule_radius.empty()) {
      const double a3 = std::pow(r.radius, 3);
      vf += a3 * static_cast<double>(species_count(r, Species::Floppy, group.ca));
      v += a3 * static_cast<double>(r.np);
      continue;
    }
    sized = true;
    const std::vector<char> m = species_mask(r, Species::Floppy, group.ca);
    for (std::size_t i = 0; i < r.np; ++i) {
      const double a3 = std::pow(r.capsule_radius.at(i), 3);
      v += a3;
      if (m[i]) vf += a3;
    }
  }
  if (sized) return v > 0.0 ? vf / v : kNaN;
  return n > 0 ? static_cast<double>(nf) / static_cast<double>(n) : kNaN;
}

int folded_bin(double y, double H, int bins) {
  const double f = fold_y(y, H) / (0.5 * H) * bins;
  if (!(f > 0.0)) return 0;  // also NaN
  const int k = static_cast<int>(std::min(f, static_cast<double>(bins - 1)));
  return k;
}

// ---------------------------------------------------------------------------------------------------------------

Window steady_window(const RunSeries& run, const AnalysisOptions& opt) {
  Window w;
  if (run.records() == 0) {
    w.rule = "no records";
    return w;
  }
  const double first = run.time.front(), last = run.time.back();
  if (std::isfinite(opt.window_start) && std::isfinite(opt.window_end)) {
    w.t0 = std::max(opt.window_start, first);
    w.t1 = std::min(opt.window_end, last);
    w.rule = "explicit window [" + fmt(opt.window_start) + ", " + fmt(opt.window_end) + "]" +
             (w.t0 != opt.window_start || w.t1 != opt.window_end ? " clipped to the run" : "");
    return w;
  }
  const double duration = last - first;
  w.t1 = last;
  if (duration >= 2.0 * opt.window_length) {
    w.t0 = last - opt.window_length;
    w.rule = "last " + fmt(opt.window_length) + " strain units (docs/analysis.md §3)";
  } else {
    w.t0 = first + 0.5 * duration;
    w.rule = "second half of a run shorter than " + fmt(2.0 * opt.window_length) + " strain units (" +
             fmt(duration) + ")";
  }
  return w;
}

std::vector<int> record_blocks(const std::vector<double>& time, const Window& w, int nblocks) {
  std::vector<int> b(time.size(), -1);
  const double len = w.t1 - w.t0;
  if (!(len >= 0.0) || nblocks <= 0) return b;
  for (std::size_t t = 0; t < time.size(); ++t) {
    if (time[t] < w.t0 || time[t] > w.t1) continue;
    const double f = len > 0.0 ? (time[t] - w.t0) / len * nblocks : 0.0;
    b[t] = std::min(static_cast<int>(f), nblocks - 1);
  }
  return b;
}

GroupBlocks group_blocks(const RunGroup& group, const AnalysisOptions& opt, int nblocks) {
  GroupBlocks gb;
  gb.nblocks = nblocks;
  for (std::size_t r = 0; r < group.runs.size(); ++r) {
    const RunSeries& run = group.runs[r];
    gb.windows.push_back(steady_window(run, opt));
    auto b = record_blocks(run.time, gb.windows.back(), nblocks);
    for (int& v : b)
      if (v >= 0) v += static_cast<int>(r) * nblocks;
    gb.block.push_back(std::move(b));
  }
  return gb;
}

Estimate block_average(const std::vector<double>& block_means) {
  std::vector<double> q;
  for (double v : block_means)
    if (std::isfinite(v)) q.push_back(v);
  if (q.empty()) return Estimate::undefined("no blocks with data");
  double mean = 0.0;
  for (double v : q) mean += v;
  mean /= static_cast<double>(q.size());
  if (q.size() < 2) return Estimate::of(mean, kNaN, "one block only: no error bar");
  double ss = 0.0;
  for (double v : q) ss += (v - mean) * (v - mean);
  const double n = static_cast<double>(q.size());
  return Estimate::of(mean, std::sqrt(ss / (n * (n - 1.0))));
}

JackknifeResult jackknife(const std::vector<std::vector<double>>& block_sums, const BlockStatistic& f) {
  JackknifeResult res;
  std::vector<const std::vector<double>*> blocks;
  std::size_t m = 0;
  for (const auto& b : block_sums) {
    if (std::any_of(b.begin(), b.end(), [](double v) { return v != 0.0; })) blocks.push_back(&b);
    m = std::max(m, b.size());
  }
  std::vector<double> total(m, 0.0);
  for (const auto* b : blocks)
    for (std::size_t j = 0; j < b->size(); ++j) total[j] += (*b)[j];
  res.value = f(total);
  res.blocks = static_cast<int>(blocks.size());
  const std::size_t nout = res.value.size();
  res.se.assign(nout, kNaN);
  if (blocks.size() < 2) return res;
  std::vector<std::vector<double>> reps;
  reps.reserve(blocks.size());
  for (const auto* b : blocks) {
    std::vector<double> s = total;
    for (std::size_t j = 0; j < b->size(); ++j) s[j] -= (*b)[j];
    reps.push_back(f(s));
    if (reps.back().size() != nout) throw std::logic_error("jackknife: statistic changed its output size");
  }
  for (std::size_t o = 0; o < nout; ++o) {
    if (!std::isfinite(res.value[o])) continue;
    double mean = 0.0;
    int n = 0;
    for (const auto& r : reps)
      if (std::isfinite(r[o])) {
        mean += r[o];
        ++n;
      }
    if (n < 2) continue;
    mean /= n;
    double ss = 0.0;
    for (const auto& r : reps)
      if (std::isfinite(r[o])) ss += (r[o] - mean) * (r[o] - mean);
    res.se[o] = std::sqrt((n - 1.0) / n * ss);
  }
  return res;
}

Estimate jackknife_ratio(const std::vector<double>& numerator, const std::vector<double>& denominator) {
  if (numerator.size() != denominator.size()) throw std::invalid_argument("jackknife_ratio: size mismatch");
  std::vector<std::vector<double>> sums(numerator.size());
  for (std::size_t b = 0; b < numerator.size(); ++b) sums[b] = {numerator[b], denominator[b]};
  const auto jk = jackknife(sums, [](const std::vector<double>& s) {
    return std::vector<double>{s[1] != 0.0 ? s[0] / s[1] : kNaN};
  });
  if (!std::isfinite(jk.value[0])) return Estimate::undefined("denominator is zero");
  return Estimate::of(jk.value[0], jk.se[0], jk.blocks < 2 ? "fewer than 2 blocks: no error bar" : "");
}

// ---------------------------------------------------------------------------------------------------------------

VolumeDrift volume_drift(const RunSeries& run, double tolerance) {
  VolumeDrift d;
  if (run.volume.empty() || run.records() == 0) return d;
  d.available = true;
  for (std::size_t i = 0; i < run.np; ++i) {
    const double v0 = run.volume[i];
    double worst = 0.0;
    for (std::size_t t = 0; t < run.records(); ++t) worst = std::max(worst, std::abs(run.volume[t * run.np + i] / v0 - 1.0));
    d.max_relative = std::max(d.max_relative, worst);
    if (worst > tolerance) d.flagged.push_back(i);
  }
  return d;
}

}  // namespace capsflow::analysis
