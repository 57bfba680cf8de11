#pragma once
// Time-resolved and trajectory analyses (issue 9; docs/analysis.md §5, §10-§12): the mean
// distance from the centreline d(t) and its steady value, the transition probability f_AB, the quasi-steady
// migration velocity of a pinned capsule, and pair collisions in simple shear.
#include <cstddef>
#include <vector>

#include "host/analysis/analysis.hpp"
#include "host/analysis/analysis_errors.hpp"

namespace capsflow::analysis {

// d-bar_X(t) / (H/2), d_i = |y_c,i - H/2| (§5), averaged over realizations at equal record index over the
// records all runs have; time is the realizations' mean record time. Every record, no smoothing.
TimeSeries d_bar_series(const RunGroup& group, Species s);

// Steady d-bar / (H/2) over the window (§5), its SE for correlated records (issue 35: block plateau,
// autocorrelation time, realizations; analysis_errors.hpp), the three-length block check (§4) and the
// steadiness check (§3).
struct DBar {
  Estimate d;                          // d-bar / (H/2), mean of the pooled block means; SE = error.se (NaN when
                                       // not estimable: then d.reason says why and error.lower_bound bounds it)
  MeanError error;                     // the estimators behind d.se (per-record series of each run's window)
  std::vector<double> block_length;    // strain: window / (2 blocks), window / blocks, window / (blocks / 2)
  std::vector<double> block_se;        // block SE at each length (§4's check; not what d carries)
  bool plateau = false;                // SE(longest) - SE(nominal) within 2 combined uncertainties of the SEs
  std::string se_rule;                 // which SE `d` carries, in words (= error.rule)
  Estimate first_half, second_half;    // d-bar / (H/2) over each half of the window (blocks / 2 blocks each)
  HalvesTest halves;                   // §3 on first_half and second_half
  bool steady = false;                 // halves.steady: |second - first| <= 2 sqrt(se1^2 + se2^2)
  std::vector<Window> windows;         // per run
};
DBar steady_d_bar(const RunGroup& group, Species s, const AnalysisOptions& opt);

// f_AB (§11): the fraction of (origin, capsule of X in A at the origin) pairs for which the capsule is in B at
// some record t with t_o < t <= t_o + horizon. A: y' < fab_region H; B: y' >= fab_region H (ties go to B).
// Origins: the first record at or after each t0 + j fab_origin_spacing with t_o + horizon <= t1 of the run's
// window. Pooled ratio of sums over origins, capsules and realizations. Undefined when a run's window is shorter
// than the horizon.
// SE (issue 35): the origins of one capsule share its few A -> B crossings, so the SE comes from independent units:
// the larger of a delete-one-capsule jackknife (each capsule's whole window one unit) and a jackknife over time
// sub-windows of origins at least the horizon long (min(fab_subwindows, floor(origin span / horizon)) per run; a
// single sub-window gives none). No crossing at all: f = 0 with no SE.
struct TransitionProbability {
  Estimate f;
  double hits = 0.0, starts = 0.0;  // pooled numerator and denominator
  std::size_t origins = 0;          // origins over all runs
  double crossings = 0.0;           // distinct A -> B crossings (record in B after one in A) inside the windows
  std::size_t capsules = 0;         // capsules of X that start in A at some origin
  std::size_t capsules_crossing = 0;  // capsules of X with at least one crossing
  int subwindows = 0;               // time sub-windows per run (largest over the runs)
  double subwindow_length = kNaN;   // strain of origins per sub-window
  Estimate se_capsules, se_time;    // the two jackknifes (jackknife_ratio; se holds the SE)
  std::string se_rule;              // which SE f carries, in words
};
TransitionProbability transition_probability(const RunGroup& group, Species s, const AnalysisOptions& opt);

// Quasi-steady migration velocity V^S of a pinned capsule (§10).
struct MigrationOptions {
  long capsule = -1;            // capsule index; -1: the first pinned capsule (capsule 0 when none is pinned)
  double average_last = 5.0;    // average over the last average_last strain units ...
  double t0 = kNaN, t1 = kNaN;  // ... unless both are set (a sub-window, clipped to the run)
  double steady_rate = 1e-4;    // steady when |dU_y/dt| / |U_y| (and the same for D) is below this, per strain
};
struct MigrationVelocity {
  std::size_t capsule = 0;
  double ca = kNaN;
  double y0 = kNaN, y0_over_H = kNaN;  // mean centroid height over the sub-window
  Estimate U_y;                        // mean U_y (as recorded, before the pin correction); se is NaN (no noise)
  Estimate v_p;                        // folded: positive toward the centreline (§1)
  double U_rate = kNaN;                // |least-squares slope of U_y| / |mean U_y|, per strain
  double D_rate = kNaN;                // same for the Taylor deformation (NaN without taylor_D)
  bool steady = false;
  Window window;
};
MigrationVelocity isolated_migration_velocity(const RunSeries& run, const MigrationOptions& opt = {});

// Pair collision in simple shear (§12). "Top" is the capsule with the larger initial y; the bottom one's
// displacement and velocity are sign-flipped so that both are positive when the pair separates.
struct PairTrack {
  std::size_t capsule = 0;
  double ca = kNaN;
  double sign = 1.0;                  // +1 top, -1 bottom
  double y_initial = kNaN;
  std::vector<double> displacement;   // sign (y - y_initial), per record
  std::vector<double> velocity;       // sign U_y, per record
  Estimate final_displacement;        // at x_top - x_bottom = final_separation, linearly interpolated
  Estimate final_speed;               // |U_y| there
  bool settled = false;               // final_speed < speed_tolerance
};
struct PairCollision {
  std::vector<double> time;           // strain since the first record
  std::vector<double> separation;     // x_top - x_bottom (unwrapped centroids)
  PairTrack top, bottom;
  Estimate crossing_time;             // strain at which separation reaches final_separation
};
PairCollision pair_collision(const RunSeries& run, double final_separation = 10.0, double speed_tolerance = 1e-3);

}  // namespace capsflow::analysis
