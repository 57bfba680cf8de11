#pragma once
// Analysis of capsflow runs for the segregation study (issue 9): the common types and the statistics machinery.
//
// Every quantity is defined in docs/analysis.md §1-§14 (cited as "§N" below); its second part says what each
// function computes and lists every place where this code fills a gap in the definitions or departs from them.
// All functions are pure: they take series already loaded into memory (RunSeries, one per run file, see
// docs/output_format.md for the datasets they mirror) and do no I/O.
//
// Life cycle for a command such as `capsflow analyze`:
//     std::vector<RunSeries> runs = ...;                     // (a) load each run's datasets
//     SpeciesCa ca = identify_species(runs);                 // stiff = smaller Ca over the whole set (§1)
//     std::vector<RunGroup> groups = group_runs(std::move(runs), ca);   // (b) realizations of one composition
//     for (const RunGroup& g : groups)                       // (c) every quantity per group and species
//       for (Species s : {Species::Stiff, Species::Floppy, Species::All}) {
//         DBar d = steady_d_bar(g, s, opt);                  // analysis_dynamics.hpp
//         Profile n = number_density(g, s, opt);             // analysis_profiles.hpp
//         ...
//       }
//
// A quantity that cannot be computed (E in a pure suspension, f_AB with a window shorter than its horizon, a
// species with no capsules) is returned as an Estimate / Profile that is not `defined`, with the `reason` in words.
// Inconsistent input (arrays of the wrong size, runs of different boxes in one group) throws InputError.
#include <cstddef>
#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace capsflow::analysis {

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// ---------------------------------------------------------------------------------------------------------------
// Input

// One run's series, flattened row-major exactly as the HDF5 datasets are (T records, np capsules).
struct RunSeries {
  std::string label;                // where the run came from (its file name): used in messages only
  double H = 0.0;                   // slit height (domain.H); walls at y = 0 and y = H
  double Lx = 0.0, Lz = 0.0;        // periods (domain.Lx, domain.Lz)
  double radius = 1.0;              // inflated capsule radius a (the unit of length): nominal volume fraction only
  std::vector<double> capsule_radius;  // [np] equal-volume radius of each capsule when the species' radii differ
                                       // (issue 23); empty: every capsule has `radius`. Nominal volume fraction only
  std::size_t np = 0;               // number of capsules
  std::vector<double> time;         // [T] /series/time, strain
  std::vector<double> centroid;     // [T np 3] /series/centroid (component 1 is y)
  std::vector<double> velocity;     // [T np 3] /series/velocity (component 1 is U_y, before any pin correction)
  std::vector<double> volume;       // [T np] /series/volume; optional (drift check, sphere model of §7)
  std::vector<double> taylor_D;     // [T np] /series/taylor_D; optional (steadiness of pinned runs, §10)
  std::vector<int> species;         // [np] /capsules/species (index into [[species]]; the slot of slab_volume)
  std::vector<double> ca;           // [np] /capsules/ca
  std::vector<char> pinned;         // [np] /capsules/pinned; optional (empty: no capsule pinned)
  // Optional slab profile (§7): the interior volume of the capsules of species slot s in slab j of slab_bins
  // equal slabs over [0, H] at record t, slab_volume[(t * slab_species + s) * slab_bins + j].
  int slab_species = 0;
  int slab_bins = 0;
  std::vector<double> slab_volume;

  std::size_t records() const { return time.size(); }
  double x(std::size_t t, std::size_t i) const { return centroid[3 * (t * np + i)]; }
  double y(std::size_t t, std::size_t i) const { return centroid[3 * (t * np + i) + 1]; }
  double uy(std::size_t t, std::size_t i) const { return velocity[3 * (t * np + i) + 1]; }
  bool has_slabs() const { return slab_bins > 0 && !slab_volume.empty(); }
};

// Throws InputError naming the run and the array when sizes disagree, H, Lx or Lz is not positive, time is not
// increasing, or a slab series is malformed.
void validate(const RunSeries& run);

// ---------------------------------------------------------------------------------------------------------------
// Results

// A scalar with its standard error, or "null with a reason".
struct Estimate {
  double value = kNaN;
  double se = kNaN;       // NaN when no error bar applies (one block, deterministic series)
  bool defined = false;
  std::string reason;     // undefined: why; defined: a caveat or flag (empty when none)

  static Estimate of(double value, double se, std::string note = {});
  static Estimate undefined(std::string why);
};

// A profile over the folded half channel (§3): bin k covers y' in [k, k+1) H / (2 bins), y' = min(y, H - y).
struct Profile {
  std::vector<double> y_over_H;  // bin centres y'/H, from the wall (0) to the centreline (0.5)
  std::vector<double> value;     // NaN where not defined
  std::vector<double> se;        // jackknife or block SE; NaN where not defined or not available
  std::vector<double> samples;   // what the value rests on: sample count (or summed volume) in the bin
  std::vector<char> defined;     // 1 where value is meaningful
  std::string reason;            // why the whole profile is unavailable, or a caveat

  bool any_defined() const;
};

// A time series averaged over realizations.
struct TimeSeries {
  std::vector<double> time;
  std::vector<double> value;
  std::string reason;  // non-empty when the series is empty or a caveat applies
};

// ---------------------------------------------------------------------------------------------------------------
// Options: one plain struct, every field with the section of docs/analysis.md it comes from.

struct AnalysisOptions {
  // Steady window (§3): the last window_length strain units, or the second half of a run shorter than
  // 2 window_length. window_start and window_end, both set, replace the rule (the window is then clipped to the run).
  double window_length = 1000.0;
  double window_start = kNaN;
  double window_end = kNaN;
  int blocks = 10;                   // blocks per run in the window (§4)
  int bins = 25;                     // folded bins over [0, H/2] (§3)
  std::size_t min_bin_samples = 200; // velocity bins with fewer pooled samples are masked (§9)
  double xf_mask = 1e-3;             // X_f-tilde undefined where phi_s + phi_f < xf_mask * phi (§8)
  // P(v_p) (§9): samples with |y' - y0| <= pdf_half_width H, velocity bins of pdf_bin_width over
  // [pdf_v_min, pdf_v_max], widened by whole bins when that holds fewer than pdf_min_coverage of the samples.
  double pdf_half_width = 0.025;
  double pdf_bin_width = 0.004;
  double pdf_v_min = -0.3;
  double pdf_v_max = 0.3;
  double pdf_min_coverage = 0.9999;
  // f_AB (§11): region A within fab_region H of either wall, B the rest; horizon in strain; origins every
  // fab_origin_spacing over [t0, t1 - horizon] of the window; SE from a jackknife over capsules and one over at most
  // fab_subwindows time sub-windows per run, each at least the horizon long (issue 35; analysis_dynamics.hpp).
  double fab_region = 0.3;
  double fab_horizon = 100.0;
  double fab_origin_spacing = 1.0;
  int fab_subwindows = 5;
};

// ---------------------------------------------------------------------------------------------------------------
// Species (§1)

enum class Species { Stiff, Floppy, All };
const char* species_name(Species s);  // "stiff", "floppy", "all"

// The capillary numbers of the two species of a set of runs: stiff is the smaller (§1).
struct SpeciesCa {
  double stiff = kNaN;
  double floppy = kNaN;
};

// The two distinct Ca values over all capsules of all runs (relative tolerance 1e-9). Throws InputError when
// there are more than two, or only one (a set of pure runs of one Ca cannot tell stiff from floppy: build the
// SpeciesCa from the whole set, or by hand).
SpeciesCa identify_species(const std::vector<RunSeries>& runs);

// Whether a capsule of capillary number ca belongs to s. Throws InputError when ca matches neither species.
bool belongs(double ca, Species s, const SpeciesCa& key);
std::vector<char> species_mask(const RunSeries& run, Species s, const SpeciesCa& key);  // [np]
std::size_t species_count(const RunSeries& run, Species s, const SpeciesCa& key);

// ---------------------------------------------------------------------------------------------------------------
// Groups of realizations (§3)

struct RunGroup {
  std::string key;              // composition_key of its runs
  SpeciesCa ca;                 // which Ca is stiff, which floppy
  std::vector<RunSeries> runs;  // realizations: same box and composition, different seeds
};

// "H=.. Lx=.. Lz=.. Np=.. Ca=0.2x40 Ca=0.5x10" (+ " pinned y=.." per pinned capsule, from its first record):
// runs with equal keys are realizations of one another.
std::string composition_key(const RunSeries& run);

// Groups runs by composition_key (in order of first appearance; runs keep their order). Validates every run.
std::vector<RunGroup> group_runs(std::vector<RunSeries> runs, const SpeciesCa& ca);

// Throws InputError unless the group has runs and they share H, Lx, Lz (relative 1e-9).
void validate_group(const RunGroup& group);

// Nominal number fraction of floppy capsules X_f = N_f / N_p, pooled over the group's runs (§1). With mixed
// sizes (RunSeries::capsule_radius; issue 23) the floppy share of the nominal volume sum a_i^3, which §1's
// X_f is for equal sizes, so that X_f-hat and E compare volume with volume.
double floppy_fraction(const RunGroup& group);

// ---------------------------------------------------------------------------------------------------------------
// Folding (§1, §3)

// y' = min(y, H - y), in [0, H/2] for a centroid inside the slit.
inline double fold_y(double y, double H) { return y < H - y ? y : H - y; }
// v_p: U_y in the lower half, -U_y in the upper half (positive toward the centreline). y = H/2 counts as lower.
inline double fold_velocity(double y, double uy, double H) { return 2.0 * y <= H ? uy : -uy; }
// Folded bin of y among `bins` equal bins over [0, H/2]; y' outside [0, H/2) is clamped into the end bins.
int folded_bin(double y, double H, int bins);

// ---------------------------------------------------------------------------------------------------------------
// Windows and blocks (§3, §4)

struct Window {
  double t0 = kNaN, t1 = kNaN;  // records with t0 <= t <= t1
  std::string rule;             // which rule chose it, in words
  double length() const { return t1 - t0; }
};

Window steady_window(const RunSeries& run, const AnalysisOptions& opt);

// Block of each record: floor(nblocks (t - t0) / (t1 - t0)), the last block closed at t1; -1 outside the window.
std::vector<int> record_blocks(const std::vector<double>& time, const Window& w, int nblocks);

// The blocks of a group: run r's blocks are numbered r * nblocks + b, pooled as independent blocks (§4).
struct GroupBlocks {
  int nblocks = 0;                       // per run
  std::vector<Window> windows;           // per run
  std::vector<std::vector<int>> block;   // per run, per record: pooled block id or -1
  int total() const { return nblocks * static_cast<int>(windows.size()); }
};
GroupBlocks group_blocks(const RunGroup& group, const AnalysisOptions& opt, int nblocks);

// Linear quantity (§4): Q = mean of the block means, SE = sqrt(sum (Q_b - Q)^2 / (n (n - 1))). Non-finite
// block means are skipped; fewer than 2 blocks give an undefined SE (value still set from one block).
Estimate block_average(const std::vector<double>& block_means);

// Delete-one-block jackknife (§4) of a vector-valued statistic f of additive per-block sums:
// value = f(sum over all blocks), Q_(b) = f(total - block b), SE^2 = (n-1)/n sum_b (Q_(b) - mean Q_(.))^2.
// Blocks whose sums are all zero (no data) are left out of n. Per output, replicates that are not finite are left
// out (n counts the finite ones); SE is NaN with fewer than 2.
struct JackknifeResult {
  std::vector<double> value;
  std::vector<double> se;
  int blocks = 0;  // non-empty blocks used
};
using BlockStatistic = std::function<std::vector<double>(const std::vector<double>& sums)>;
JackknifeResult jackknife(const std::vector<std::vector<double>>& block_sums, const BlockStatistic& f);

// Ratio of pooled sums, sum num / sum den, with its jackknife SE. Undefined when sum den == 0.
Estimate jackknife_ratio(const std::vector<double>& numerator, const std::vector<double>& denominator);

// ---------------------------------------------------------------------------------------------------------------
// Checks (§14)

struct VolumeDrift {
  double max_relative = 0.0;               // max over capsules and records of |V(t) / V(t_0) - 1|
  std::vector<std::size_t> flagged;        // capsules exceeding the tolerance
  bool available = false;                  // false when the run has no volume series
};
VolumeDrift volume_drift(const RunSeries& run, double tolerance = 0.02);

}  // namespace capsflow::analysis
