// The implementation of analysis_profiles.hpp: the steady profiles across the slit (n-hat to v'_p).
#include "host/analysis/analysis_profiles.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "host/base/errors.hpp"
#include "host/base/math_constants.hpp"

namespace capsflow::analysis {
namespace {

Profile empty_profile(int bins, std::string reason) {
  Profile p;
  const auto n = static_cast<std::size_t>(bins);
  p.y_over_H.resize(n);
  for (std::size_t k = 0; k < n; ++k) p.y_over_H[k] = (static_cast<double>(k) + 0.5) / (2.0 * bins);
  p.value.assign(n, kNaN);
  p.se.assign(n, kNaN);
  p.samples.assign(n, 0.0);
  p.defined.assign(n, 0);
  p.reason = std::move(reason);
  return p;
}

void require_bins(const AnalysisOptions& opt) {
  if (opt.bins <= 0) throw InputError("analysis: bins must be positive");
  if (opt.blocks <= 0) throw InputError("analysis: blocks must be positive");
}

std::size_t uz(int v) { return static_cast<std::size_t>(v); }

// Capsules of species s in the group, summed over runs (0 means the species is absent).
std::size_t group_count(const RunGroup& g, Species s) {
  std::size_t n = 0;
  for (const RunSeries& r : g.runs) n += species_count(r, s, g.ca);
  return n;
}

std::string absent(Species s) { return std::string("no ") + species_name(s) + " capsules in this group"; }

// Volume of the capsules of species s in each folded bin at every record: out[t * bins + k] (§7).
// Returns an empty string on success, else the reason the source is unavailable for this run.
std::string folded_species_volume(const RunSeries& run, Species s, const SpeciesCa& key, int bins,
                                  VolumeSource source, std::vector<double>& out) {
  std::vector<double> sphere;
  const std::vector<double>* slabs = &run.slab_volume;
  int nslab = run.slab_bins, nslot = run.slab_species;
  if (source == VolumeSource::Spheres) {
    if (run.volume.empty()) return "run '" + run.label + "' has no volume series for the sphere model";
    nslab = 2 * bins;
    sphere = sphere_slab_volumes(run, nslab);
    nslot = 1 + (run.species.empty() ? 0 : *std::max_element(run.species.begin(), run.species.end()));
    slabs = &sphere;
  } else {
    if (!run.has_slabs()) return "run '" + run.label + "' has no slab-volume series";
    if (nslab % (2 * bins) != 0)
      return "run '" + run.label + "' has " + std::to_string(nslab) + " slabs: need a multiple of " +
             std::to_string(2 * bins) + " (2 x bins) so that the folded bin edges are slab edges";
  }
  // Slots of species s: every capsule of the slot must agree (a slot mixing stiff and floppy cannot be split).
  std::vector<char> use(uz(nslot), s == Species::All ? 1 : 0);
  if (s != Species::All) {
    std::vector<int> yes(uz(nslot), 0), no(uz(nslot), 0);
    for (std::size_t i = 0; i < run.np; ++i) (belongs(run.ca[i], s, key) ? yes : no)[uz(run.species[i])]++;
    for (std::size_t q = 0; q < uz(nslot); ++q) {
      if (yes[q] && no[q])
        throw InputError("run '" + run.label + "': species slot " + std::to_string(q) +
                         " holds both stiff and floppy capsules");
      use[q] = yes[q] > 0;
    }
  }
  const int m = nslab / (2 * bins);  // slabs per folded bin and half
  std::vector<int> fold(uz(nslab));
  for (int j = 0; j < nslab; ++j) fold[uz(j)] = (j < nslab / 2 ? j : nslab - 1 - j) / m;
  const std::size_t T = run.records();
  out.assign(T * uz(bins), 0.0);
  for (std::size_t t = 0; t < T; ++t)
    for (std::size_t q = 0; q < uz(nslot); ++q) {
      if (!use[q]) continue;
      const double* v = slabs->data() + (t * uz(nslot) + q) * uz(nslab);
      for (std::size_t j = 0; j < uz(nslab); ++j) out[t * uz(bins) + uz(fold[j])] += v[j];
    }
  return {};
}

// Pooled per-block sums of the folded volumes of one species: sums[b] = {S_0 .. S_{bins-1}, records}.
// Empty reason on success.
std::string block_volume_sums(const RunGroup& g, Species s, const AnalysisOptions& opt, VolumeSource source,
                              const GroupBlocks& gb, std::vector<std::vector<double>>& sums) {
  const int nb = opt.bins;
  sums.assign(uz(gb.total()), std::vector<double>(uz(nb) + 1, 0.0));
  std::vector<double> vol;
  for (std::size_t r = 0; r < g.runs.size(); ++r) {
    const RunSeries& run = g.runs[r];
    std::string why = folded_species_volume(run, s, g.ca, nb, source, vol);
    if (!why.empty()) return why;
    for (std::size_t t = 0; t < run.records(); ++t) {
      const int b = gb.block[r][t];
      if (b < 0) continue;
      auto& acc = sums[uz(b)];
      for (std::size_t k = 0; k < uz(nb); ++k) acc[k] += vol[t * uz(nb) + k];
      acc[uz(nb)] += 1.0;
    }
  }
  return {};
}

// Sphere of volume V at height yc: volume below the plane y = c.
double sphere_below(double yc, double r, double c) {
  const double h = std::min(std::max(c - (yc - r), 0.0), 2.0 * r);
  return kPi * h * h * (3.0 * r - h) / 3.0;
}

}  // namespace

// ---------------------------------------------------------------------------------------------------------------

Profile number_density(const RunGroup& g, Species s, const AnalysisOptions& opt) {
  validate_group(g);
  require_bins(opt);
  const int nb = opt.bins;
  if (group_count(g, s) == 0) return empty_profile(nb, absent(s));
  const GroupBlocks gb = group_blocks(g, opt, opt.blocks);
  // Per block: c_0 .. c_{nb-1}, then the number of (record, capsule of s) samples.
  std::vector<std::vector<double>> sums(uz(gb.total()), std::vector<double>(uz(nb) + 1, 0.0));
  for (std::size_t r = 0; r < g.runs.size(); ++r) {
    const RunSeries& run = g.runs[r];
    const auto mask = species_mask(run, s, g.ca);
    const double nx = static_cast<double>(std::count(mask.begin(), mask.end(), 1));
    for (std::size_t t = 0; t < run.records(); ++t) {
      const int b = gb.block[r][t];
      if (b < 0) continue;
      auto& acc = sums[uz(b)];
      for (std::size_t i = 0; i < run.np; ++i)
        if (mask[i]) acc[uz(folded_bin(run.y(t, i), run.H, nb))] += 1.0;
      acc[uz(nb)] += nx;
    }
  }
  // n-hat(k) = c_k / (D 2 dy / H), D = M N_X, 2 dy / H = 1 / bins.
  const auto jk = jackknife(sums, [nb](const std::vector<double>& S) {
    std::vector<double> out(uz(nb), kNaN);
    if (S[uz(nb)] > 0.0)
      for (std::size_t k = 0; k < uz(nb); ++k) out[k] = nb * S[k] / S[uz(nb)];
    return out;
  });
  Profile p = empty_profile(nb, {});
  if (jk.blocks == 0) {
    p.reason = "no records in the steady window";
    return p;
  }
  for (std::size_t k = 0; k < uz(nb); ++k) {
    p.value[k] = jk.value[k];
    p.se[k] = jk.se[k];
    p.defined[k] = std::isfinite(jk.value[k]) ? 1 : 0;
    for (const auto& b : sums) p.samples[k] += b[k];
  }
  if (jk.blocks < 2) p.reason = "fewer than 2 blocks: no error bars";
  return p;
}

// ---------------------------------------------------------------------------------------------------------------

std::vector<double> sphere_slab_volumes(const RunSeries& run, int nbins) {
  validate(run);
  if (run.volume.empty()) throw InputError("sphere_slab_volumes: run '" + run.label + "' has no volume series");
  if (nbins <= 0) throw InputError("sphere_slab_volumes: nbins must be positive");
  const std::size_t nslot =
      1 + uz(run.species.empty() ? 0 : *std::max_element(run.species.begin(), run.species.end()));
  const std::size_t T = run.records(), nb = uz(nbins);
  std::vector<double> out(T * nslot * nb, 0.0);
  const double H = run.H, w = H / nbins;
  for (std::size_t t = 0; t < T; ++t)
    for (std::size_t i = 0; i < run.np; ++i) {
      const double V = run.volume[t * run.np + i];
      if (!(V > 0.0)) continue;
      const double r = std::cbrt(3.0 * V / (4.0 * kPi)), yc = run.y(t, i);
      const double lo = std::clamp((yc - r) / w, 0.0, nbins - 1.0), hi = std::clamp((yc + r) / w, 0.0, nbins - 1.0);
      const int jlo = static_cast<int>(lo), jhi = static_cast<int>(hi);
      double* o = out.data() + (t * nslot + uz(run.species[i])) * nb;
      double below = sphere_below(yc, r, H * jlo / nbins);
      for (int j = jlo; j <= jhi; ++j) {
        const double next = sphere_below(yc, r, H * (j + 1) / nbins);
        o[j] += next - below;
        below = next;
      }
    }
  return out;
}

VolumeFractionProfile volume_fraction_profile(const RunGroup& g, Species s, const AnalysisOptions& opt,
                                              VolumeSource source) {
  validate_group(g);
  require_bins(opt);
  const int nb = opt.bins;
  VolumeFractionProfile res;
  res.source = source;
  if (group_count(g, s) == 0) {
    res.phi = res.phi_hat = empty_profile(nb, absent(s));
    return res;
  }
  const RunSeries& r0 = g.runs.front();
  const double H = r0.H, LxLz = r0.Lx * r0.Lz, dy = 0.5 * H / nb;
  if (r0.capsule_radius.empty()) {
    res.phi_bar_nominal = static_cast<double>(group_count(g, s)) / static_cast<double>(g.runs.size()) * 4.0 / 3.0 *
                          kPi * std::pow(r0.radius, 3) / (LxLz * H);
  } else {  // mixed sizes: the selected capsules' own volumes
    double v = 0.0;
    for (const RunSeries& r : g.runs) {
      const std::vector<char> m = species_mask(r, s, g.ca);
      for (std::size_t i = 0; i < r.np; ++i)
        if (m[i]) v += 4.0 / 3.0 * kPi * std::pow(r.capsule_radius.at(i), 3);
    }
    res.phi_bar_nominal = v / static_cast<double>(g.runs.size()) / (LxLz * H);
  }
  const GroupBlocks gb = group_blocks(g, opt, opt.blocks);
  std::vector<std::vector<double>> sums;
  const std::string why = block_volume_sums(g, s, opt, source, gb, sums);
  if (!why.empty()) {
    res.phi = res.phi_hat = empty_profile(nb, why);
    return res;
  }
  // Outputs: phi_0.., phi-hat_0.., phi-bar. F = records, V = sum over bins (= the species' volume inside [0, H]).
  const auto jk = jackknife(sums, [nb, H, LxLz, dy](const std::vector<double>& S) {
    std::vector<double> out(2 * uz(nb) + 1, kNaN);
    const double F = S[uz(nb)];
    double V = 0.0;
    for (std::size_t k = 0; k < uz(nb); ++k) V += S[k];
    if (!(F > 0.0)) return out;
    for (std::size_t k = 0; k < uz(nb); ++k) {
      out[k] = S[k] / (F * LxLz * 2.0 * dy);
      if (V > 0.0) out[uz(nb) + k] = nb * S[k] / V;
    }
    out[2 * uz(nb)] = V / (F * LxLz * H);
    return out;
  });
  res.phi = empty_profile(nb, {});
  res.phi_hat = empty_profile(nb, {});
  if (jk.blocks == 0) {
    res.phi.reason = res.phi_hat.reason = "no records in the steady window";
    return res;
  }
  for (std::size_t k = 0; k < uz(nb); ++k) {
    double vol = 0.0;
    for (const auto& b : sums) vol += b[k];
    for (Profile* p : {&res.phi, &res.phi_hat}) p->samples[k] = vol;
    res.phi.value[k] = jk.value[k];
    res.phi.se[k] = jk.se[k];
    res.phi.defined[k] = std::isfinite(jk.value[k]) ? 1 : 0;
    res.phi_hat.value[k] = jk.value[uz(nb) + k];
    res.phi_hat.se[k] = jk.se[uz(nb) + k];
    res.phi_hat.defined[k] = std::isfinite(jk.value[uz(nb) + k]) ? 1 : 0;
  }
  res.phi_bar = jk.value[2 * uz(nb)];
  if (jk.blocks < 2) res.phi.reason = res.phi_hat.reason = "fewer than 2 blocks: no error bars";
  return res;
}

double max_abs_difference(const Profile& a, const Profile& b) {
  double m = kNaN;
  const std::size_t n = std::min(a.value.size(), b.value.size());
  for (std::size_t k = 0; k < n; ++k)
    if (a.defined[k] && b.defined[k]) {
      const double d = std::abs(a.value[k] - b.value[k]);
      m = std::isnan(m) ? d : std::max(m, d);
    }
  return m;
}

// ---------------------------------------------------------------------------------------------------------------

Enrichment enrichment(const RunGroup& g, const AnalysisOptions& opt, VolumeSource source) {
  validate_group(g);
  require_bins(opt);
  const int nb = opt.bins;
  const std::size_t n = uz(nb);
  Enrichment e;
  e.xf = floppy_fraction(g);
  e.xf_tilde = e.xf_hat = empty_profile(nb, {});
  const GroupBlocks gb = group_blocks(g, opt, opt.blocks);
  std::vector<std::vector<double>> ss, sf;
  std::string why = block_volume_sums(g, Species::Stiff, opt, source, gb, ss);
  if (why.empty()) why = block_volume_sums(g, Species::Floppy, opt, source, gb, sf);
  if (!why.empty()) {
    e.xf_tilde.reason = e.xf_hat.reason = why;
    for (Estimate* q : {&e.E_f, &e.E_s, &e.E_f_contiguous, &e.E_s_contiguous, &e.y_star_over_H})
      *q = Estimate::undefined(why);
    return e;
  }
  // Per block: S_s(0..n-1), S_f(0..n-1), records.
  std::vector<std::vector<double>> sums(ss.size());
  for (std::size_t b = 0; b < ss.size(); ++b) {
    sums[b].assign(ss[b].begin(), ss[b].begin() + static_cast<long>(n));
    sums[b].insert(sums[b].end(), sf[b].begin(), sf[b].end());  // S_f and records
  }
  const double xf = e.xf, xs = 1.0 - xf, mask = opt.xf_mask;
  const bool mixture = xf > 0.0 && xf < 1.0;
  // Outputs: xf_tilde[n], xf_hat[n], E_f, E_s, E_f_contiguous, E_s_contiguous, y*/H, xf_volume.
  const std::size_t oE = 2 * n;
  const auto stat = [n, nb, xf, xs, mask, mixture, oE](const std::vector<double>& S) {
    std::vector<double> out(oE + 6, kNaN);
    const double* Ss = S.data();
    const double* Sf = S.data() + n;
    double tot_s = 0.0, tot_f = 0.0;
    for (std::size_t k = 0; k < n; ++k) {
      tot_s += Ss[k];
      tot_f += Sf[k];
    }
    if (!(tot_s + tot_f > 0.0)) return out;
    out[oE + 5] = tot_f / (tot_s + tot_f);
    // Bin k is masked where phi_s + phi_f < mask * phi: in sums, S_s + S_f < mask * (total) / bins.
    std::vector<char> def(n, 0);
    for (std::size_t k = 0; k < n; ++k) {
      const double t = Ss[k] + Sf[k];
      def[k] = t > 0.0 && t >= mask * (tot_s + tot_f) / nb;
      if (def[k]) {
        out[k] = Sf[k] / t;
        if (xf > 0.0) out[n + k] = out[k] / xf;
      }
    }
    if (!mixture) return out;
    const auto ratio = [&](auto in_region, const double* num, double frac) {
      double a = 0.0, b = 0.0;
      for (std::size_t k = 0; k < n; ++k)
        if (def[k] && in_region(k)) {
          a += num[k];
          b += Ss[k] + Sf[k];
        }
      return b > 0.0 ? a / b / frac : kNaN;
    };
    out[oE] = ratio([&](std::size_t k) { return out[n + k] >= 1.0; }, Sf, xf);
    out[oE + 1] = ratio([&](std::size_t k) { return out[k] <= xf; }, Ss, xs);
    // y*: walk from the defined bin nearest the centreline toward the wall until X_f-hat - 1 changes side.
    long kc = static_cast<long>(n) - 1;
    while (kc >= 0 && !def[static_cast<std::size_t>(kc)]) --kc;
    if (kc < 1) return out;
    const auto h = [&](long k) { return out[n + static_cast<std::size_t>(k)]; };
    const bool centre_enriched = h(kc) >= 1.0;
    long k = kc - 1;
    while (k >= 0 && def[static_cast<std::size_t>(k)] && (h(k) >= 1.0) == centre_enriched) --k;
    if (k < 0 || !def[static_cast<std::size_t>(k)]) return out;
    // Crossing between the centres of bins k and k + 1.
    const double kd = static_cast<double>(k);
    const double yk = (kd + 0.5) / (2.0 * nb), yk1 = (kd + 1.5) / (2.0 * nb);
    out[oE + 4] = yk + (1.0 - h(k)) / (h(k + 1) - h(k)) * (yk1 - yk);
    const auto upper = [k](std::size_t j) { return static_cast<long>(j) > k; };
    const auto lower = [k](std::size_t j) { return static_cast<long>(j) <= k; };
    if (centre_enriched) {
      out[oE + 2] = ratio(upper, Sf, xf);
      out[oE + 3] = ratio(lower, Ss, xs);
    } else {
      out[oE + 2] = ratio(lower, Sf, xf);
      out[oE + 3] = ratio(upper, Ss, xs);
    }
    return out;
  };
  const auto jk = jackknife(sums, stat);
  if (jk.blocks == 0) {
    e.xf_tilde.reason = e.xf_hat.reason = "no records in the steady window";
    for (Estimate* q : {&e.E_f, &e.E_s, &e.E_f_contiguous, &e.E_s_contiguous, &e.y_star_over_H})
      *q = Estimate::undefined("no records in the steady window");
    return e;
  }
  for (std::size_t k = 0; k < n; ++k) {
    double vol = 0.0;
    for (const auto& b : sums) vol += b[k] + b[n + k];
    e.xf_tilde.samples[k] = e.xf_hat.samples[k] = vol;
    e.xf_tilde.value[k] = jk.value[k];
    e.xf_tilde.se[k] = jk.se[k];
    e.xf_tilde.defined[k] = std::isfinite(jk.value[k]) ? 1 : 0;
    e.xf_hat.value[k] = jk.value[n + k];
    e.xf_hat.se[k] = jk.se[n + k];
    e.xf_hat.defined[k] = std::isfinite(jk.value[n + k]) ? 1 : 0;
  }
  e.xf_volume = jk.value[oE + 5];
  e.xf_volume_flag = std::abs(e.xf_volume - e.xf) > 0.01 * e.xf;
  const auto est = [&](std::size_t o, const char* what) {
    if (!mixture)
      return Estimate::undefined("pure suspension (X_f = " + std::to_string(xf) +
                                 "): E and y* are defined only for mixtures (§8)");
    if (!std::isfinite(jk.value[o])) return Estimate::undefined(what);
    return Estimate::of(jk.value[o], jk.se[o], jk.blocks < 2 ? "fewer than 2 blocks: no error bar" : "");
  };
  e.E_f = est(oE, "no defined bin with X_f-hat >= 1");
  e.E_s = est(oE + 1, "no defined bin with X_f-tilde <= X_f");
  e.E_f_contiguous = est(oE + 2, "no crossing X_f-hat = 1 between defined bins");
  e.E_s_contiguous = est(oE + 3, "no crossing X_f-hat = 1 between defined bins");
  e.y_star_over_H = est(oE + 4, "no crossing X_f-hat = 1 between defined bins");
  if (e.xf_volume_flag) {
    const std::string flag = "volume share X_f^vol = " + std::to_string(e.xf_volume) +
                             " differs from X_f by more than 1% (differential volume drift)";
    e.xf_hat.reason = flag;
    for (Estimate* q : {&e.E_f, &e.E_s})
      if (q->defined) q->reason += (q->reason.empty() ? "" : "; ") + flag;
  }
  return e;
}

// ---------------------------------------------------------------------------------------------------------------

VelocityProfile velocity_profile(const RunGroup& g, Species s, const AnalysisOptions& opt) {
  validate_group(g);
  require_bins(opt);
  const int nb = opt.bins;
  const std::size_t n = uz(nb);
  VelocityProfile vp;
  if (group_count(g, s) == 0) {
    vp.mean = vp.fluctuation = empty_profile(nb, absent(s));
    return vp;
  }
  const GroupBlocks gb = group_blocks(g, opt, opt.blocks);
  // Per block: count(k), sum v_p(k), sum v_p^2(k).
  std::vector<std::vector<double>> sums(uz(gb.total()), std::vector<double>(3 * n, 0.0));
  for (std::size_t r = 0; r < g.runs.size(); ++r) {
    const RunSeries& run = g.runs[r];
    const auto mask = species_mask(run, s, g.ca);
    for (std::size_t t = 0; t < run.records(); ++t) {
      const int b = gb.block[r][t];
      if (b < 0) continue;
      auto& acc = sums[uz(b)];
      for (std::size_t i = 0; i < run.np; ++i) {
        if (!mask[i]) continue;
        const double y = run.y(t, i), v = fold_velocity(y, run.uy(t, i), run.H);
        const std::size_t k = uz(folded_bin(y, run.H, nb));
        acc[k] += 1.0;
        acc[n + k] += v;
        acc[2 * n + k] += v * v;
      }
    }
  }
  const auto jk = jackknife(sums, [n](const std::vector<double>& S) {
    std::vector<double> out(2 * n, kNaN);
    for (std::size_t k = 0; k < n; ++k) {
      if (!(S[k] > 0.0)) continue;
      const double m = S[n + k] / S[k];
      out[k] = m;
      out[n + k] = std::sqrt(std::max(S[2 * n + k] / S[k] - m * m, 0.0));
    }
    return out;
  });
  vp.mean = empty_profile(nb, {});
  vp.fluctuation = empty_profile(nb, {});
  if (jk.blocks == 0) {
    vp.mean.reason = vp.fluctuation.reason = "no records in the steady window";
    return vp;
  }
  for (std::size_t k = 0; k < n; ++k) {
    double count = 0.0;
    for (const auto& b : sums) count += b[k];
    const bool ok = count >= static_cast<double>(opt.min_bin_samples) && std::isfinite(jk.value[k]);
    for (Profile* p : {&vp.mean, &vp.fluctuation}) {
      p->samples[k] = count;
      p->defined[k] = ok ? 1 : 0;
    }
    if (!ok) continue;
    vp.mean.value[k] = jk.value[k];
    vp.mean.se[k] = jk.se[k];
    vp.fluctuation.value[k] = jk.value[n + k];
    vp.fluctuation.se[k] = jk.se[n + k];
  }
  return vp;
}

Profile relative_velocity_change(const Profile& mix, const Profile& ref) {
  if (mix.value.size() != ref.value.size())
    throw InputError("relative_velocity_change: the mixture and reference profiles have different bins");
  Profile p = mix;
  p.reason.clear();
  for (std::size_t k = 0; k < p.value.size(); ++k) {
    const double v = mix.value[k], vr = ref.value[k], se_v = mix.se[k], se_r = ref.se[k];
    // |v_r| < 2 SE(v_r): the reference is indistinguishable from zero; an unknown SE does not mask.
    const bool ok = mix.defined[k] && ref.defined[k] && vr != 0.0 && !(std::abs(vr) < 2.0 * se_r);
    p.defined[k] = ok ? 1 : 0;
    p.samples[k] = mix.samples[k];
    if (!ok) {
      p.value[k] = p.se[k] = kNaN;
      continue;
    }
    p.value[k] = (v - vr) / vr;
    const double a = se_v / vr, b = v * se_r / (vr * vr);
    p.se[k] = std::sqrt(a * a + b * b);
  }
  return p;
}

// ---------------------------------------------------------------------------------------------------------------

VelocityPdf velocity_pdf(const RunGroup& g, Species s, double y0_over_H, const AnalysisOptions& opt) {
  validate_group(g);
  if (!(opt.pdf_bin_width > 0.0) || !(opt.pdf_v_max > opt.pdf_v_min))
    throw InputError("velocity_pdf: need pdf_bin_width > 0 and pdf_v_max > pdf_v_min");
  VelocityPdf pdf;
  pdf.y0_over_H = y0_over_H;
  pdf.half_width_over_H = opt.pdf_half_width;
  std::vector<double> v;
  for (const RunSeries& run : g.runs) {
    const Window w = steady_window(run, opt);
    const auto mask = species_mask(run, s, g.ca);
    const double y0 = y0_over_H * run.H, hw = opt.pdf_half_width * run.H;
    for (std::size_t t = 0; t < run.records(); ++t) {
      if (run.time[t] < w.t0 || run.time[t] > w.t1) continue;
      for (std::size_t i = 0; i < run.np; ++i) {
        if (!mask[i]) continue;
        const double y = run.y(t, i);
        if (std::abs(fold_y(y, run.H) - y0) <= hw) v.push_back(fold_velocity(y, run.uy(t, i), run.H));
      }
    }
  }
  pdf.samples = v.size();
  const double wbin = opt.pdf_bin_width;
  long nlo = 0, nhi = std::lround((opt.pdf_v_max - opt.pdf_v_min) / wbin);  // edges v_min + k w, k in [nlo, nhi]
  if (v.empty()) {
    pdf.reason = group_count(g, s) == 0 ? absent(s) : "no samples in the y window";
    return pdf;
  }
  const double nominal_hi = opt.pdf_v_min + static_cast<double>(nhi) * wbin;
  std::size_t inside = 0;
  double sum = 0.0, vmin = v.front(), vmax = v.front();
  for (double x : v) {
    inside += x >= opt.pdf_v_min && x <= nominal_hi;
    sum += x;
    vmin = std::min(vmin, x);
    vmax = std::max(vmax, x);
  }
  const double ns = static_cast<double>(v.size());
  pdf.mean = sum / ns;
  double ss = 0.0;
  for (double x : v) ss += (x - pdf.mean) * (x - pdf.mean);
  pdf.stddev = std::sqrt(ss / ns);
  pdf.coverage = static_cast<double>(inside) / ns;
  if (pdf.coverage < opt.pdf_min_coverage) {
    // Widen by whole bins on the same lattice, so the curves at different y0 stay comparable.
    pdf.widened = true;
    nlo = std::min(nlo, static_cast<long>(std::floor((vmin - opt.pdf_v_min) / wbin)));
    nhi = std::max(nhi, static_cast<long>(std::ceil((vmax - opt.pdf_v_min) / wbin)));
    pdf.reason = "velocity range widened: [pdf_v_min, pdf_v_max] held " + std::to_string(100.0 * pdf.coverage) +
                 "% of the samples";
  }
  const std::size_t nbin = static_cast<std::size_t>(nhi - nlo);
  pdf.edges.resize(nbin + 1);
  for (std::size_t k = 0; k <= nbin; ++k)
    pdf.edges[k] = opt.pdf_v_min + static_cast<double>(nlo + static_cast<long>(k)) * wbin;
  pdf.counts.assign(nbin, 0);
  for (double x : v) {
    const double f = (x - pdf.edges.front()) / wbin;
    if (f < 0.0 || x > pdf.edges.back()) continue;
    pdf.counts[std::min(static_cast<std::size_t>(f), nbin - 1)]++;
  }
  pdf.density.resize(nbin);
  for (std::size_t k = 0; k < nbin; ++k) pdf.density[k] = static_cast<double>(pdf.counts[k]) / (ns * wbin);
  return pdf;
}

}  // namespace capsflow::analysis
