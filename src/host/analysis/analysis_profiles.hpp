#pragma once
// Steady-state profiles across the slit (issue 9; docs/analysis.md §6-§9): number
// density n-hat, volume fraction phi and phi-hat, the floppy fraction X_f-tilde / X_f-hat with the enrichment
// factors E_f, E_s and the crossing y*, mean and fluctuation of the folded wall-normal velocity, its change relative
// to a pure suspension, and P(v_p).
//
// Every profile pools all (record in the steady window, capsule of the species, realization) samples of a group
// (§3) into `opt.bins` folded bins over [0, H/2] (§3), and carries a delete-one-block jackknife SE over
// opt.blocks blocks per run (§4).
#include "host/analysis/analysis.hpp"

namespace capsflow::analysis {

// n-hat(k) = c_k / (M N_X 2 dy / H) (§6): c_k pooled centroid samples in folded bin k, M N_X the pooled
// number of (record, capsule) samples of the species. The uniform reference spans the whole height, so
// (2/H) sum_k n-hat(k) dy = 1 exactly. samples = c_k. Undefined (reason) when the species has no capsules.
Profile number_density(const RunGroup& group, Species s, const AnalysisOptions& opt);

// Where the capsule volume per slab comes from (§7).
enum class VolumeSource {
  MeshSlabs,  // the recorded exact slab volumes of the meshes (RunSeries::slab_volume)
  Spheres,    // fallback: a sphere of the capsule's recorded volume at its centroid (needs RunSeries::volume)
};

struct VolumeFractionProfile {
  VolumeSource source = VolumeSource::MeshSlabs;
  Profile phi;      // phi_X(k): window-averaged folded volume fraction, sum of both slabs / (Lx Lz 2 dy)
  Profile phi_hat;  // phi_X(k) / phi-bar_X; (2/H) sum_k phi-hat(k) dy = 1 exactly
  double phi_bar = kNaN;          // measured mean volume fraction of the species: window-averaged volume / (Lx H Lz)
  double phi_bar_nominal = kNaN;  // N_X (4/3) pi a^3 / (Lx H Lz), a = RunSeries::radius
};

// phi and phi-hat (§7) of a species. MeshSlabs needs every run's slab series with slab_bins a multiple of
// 2 opt.bins (the folded bin edges must be slab edges, so the re-binning is exact); otherwise the profile is
// undefined with the reason. Spheres needs the volume series. samples = pooled volume in the bin.
VolumeFractionProfile volume_fraction_profile(const RunGroup& group, Species s, const AnalysisOptions& opt,
                                              VolumeSource source = VolumeSource::MeshSlabs);

// The sphere model's slab series of one run (§7 fallback) in the layout of RunSeries::slab_volume, with
// slab_species = max species index + 1: each capsule a sphere of radius (3 V_i / 4 pi)^(1/3) at its centroid,
// V_below(c) = pi h^2 (3 r - h) / 3, h = clamp(c - (y_c - r), 0, 2 r). Throws InputError without a volume series.
std::vector<double> sphere_slab_volumes(const RunSeries& run, int nbins);

// Largest |a - b| over bins where both are defined (NaN when there are none): e.g. mesh vs sphere phi-hat.
double max_abs_difference(const Profile& a, const Profile& b);

// X_f-tilde, X_f-hat, E_f, E_s and y* (§8), with jackknife SEs (the regions are re-derived in every
// replicate).
struct Enrichment {
  Profile xf_tilde;              // phi_f / (phi_s + phi_f); undefined where phi_s + phi_f < opt.xf_mask phi
  Profile xf_hat;                // xf_tilde / X_f
  double xf = kNaN;              // nominal number fraction N_f / N_p (the normalisation, as in the paper)
  double xf_volume = kNaN;       // volume share V_f / (V_s + V_f) over the window
  bool xf_volume_flag = false;   // |xf_volume - xf| > 0.01 xf: differential volume drift
  Estimate E_f, E_s;             // literal: R_f = {X_f-hat >= 1}, R_s = {X_f-tilde <= X_f}, over defined bins
  Estimate E_f_contiguous;       // R_f = the bins on the floppy-enriched side of y* (a single contiguous region)
  Estimate E_s_contiguous;       // R_s = the defined bins on the other side of y*
  Estimate y_star_over_H;        // X_f-hat = 1 crossing nearest the centreline, linear between bin centres
};
Enrichment enrichment(const RunGroup& group, const AnalysisOptions& opt,
                      VolumeSource source = VolumeSource::MeshSlabs);

// v-bar_p(k) (§9) and v'_p(k) = sqrt(<v_p^2>_k - v-bar_p(k)^2) (§9) of the folded velocity v_p, binned
// by the folded centroid of the same record. Bins with fewer than opt.min_bin_samples pooled samples are undefined.
// samples = pooled count.
struct VelocityProfile {
  Profile mean;         // v-bar_p
  Profile fluctuation;  // v'_p
};
VelocityProfile velocity_profile(const RunGroup& group, Species s, const AnalysisOptions& opt);

// (v-bar_p - v_r) / v_r per bin (§9), v_r the same species' v-bar_p in its pure suspension, same bins.
// Undefined where either is undefined or |v_r| < 2 SE(v_r). SE^2 = (SE_v / v_r)^2 + (v-bar_p SE_r / v_r^2)^2.
Profile relative_velocity_change(const Profile& mixture_mean, const Profile& reference_mean);

// P(v_p) at y0 (§9): samples with |y' - y0| <= opt.pdf_half_width H, fixed velocity bins.
struct VelocityPdf {
  double y0_over_H = kNaN;
  double half_width_over_H = kNaN;
  std::vector<double> edges;         // bin edges [nbins + 1]: pdf_v_min + k pdf_bin_width (widened if needed)
  std::vector<double> density;       // counts / (samples * bin width): integrates to `coverage`
  std::vector<std::size_t> counts;
  std::size_t samples = 0;           // samples in the y window
  double coverage = kNaN;            // fraction of samples inside the nominal [pdf_v_min, pdf_v_max]
  bool widened = false;              // true when the nominal range held fewer than pdf_min_coverage
  double mean = kNaN, stddev = kNaN; // of the samples (for a Gaussian overlay)
  std::string reason;                // why it is empty, or a caveat
};
VelocityPdf velocity_pdf(const RunGroup& group, Species s, double y0_over_H, const AnalysisOptions& opt);

}  // namespace capsflow::analysis
