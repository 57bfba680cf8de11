#pragma once
// Standard errors of time averages of correlated series (issue 35; docs/analysis.md, "Errors of correlated series").
//
// A time average over a window of a run (d-bar over the steady window) is the mean of a series whose records are
// correlated over many records. Two estimators of the standard error (SE) of such a mean, each of which says when it
// cannot give one instead of returning a small number:
//
//   - block_sweep: Flyvbjerg-Petersen block averaging at block sizes 1, 2, 4, ... records. The SE is read at the
//     optimal block size of Lee, Needs and Drummond (B^3 > 2 N (SE_B / SE_1)^4, the size at which the bias of the
//     block SE is about its statistical error), and only if no larger usable block exceeds it by more than twice
//     their combined uncertainty (the plateau). A series whose block SE still grows at the largest usable block
//     (at least min_blocks blocks) has no estimable SE: the result is undefined with the reason and the largest
//     usable block SE as a lower bound.
//   - autocorrelation_time: the integrated autocorrelation time tau_int = 1/2 + sum_t rho(t) by Sokal's automatic
//     window (the smallest M with M >= c tau_int(M)), SE = sqrt(2 tau_int C(0) / N). Undefined when no window is
//     found within the series or the series is shorter than min_length tau_int.
//
// For an AR(1) series x_t = rho x_{t-1} + e_t both converge to the exact SE of the mean,
// sigma_x sqrt(2 tau_int / N) with tau_int = (1 + rho) / (2 (1 - rho)) (tests/test_analysis_errors.cpp).
#include <cstddef>
#include <string>
#include <vector>

#include "host/analysis/analysis.hpp"

namespace capsflow::analysis {

struct BlockLevel {
  std::size_t block = 0;    // records per block (2^k)
  std::size_t blocks = 0;   // number of whole blocks (the records after the last whole block are left out)
  double se = kNaN;         // sqrt(sum (B_i - mean B)^2 / (n (n - 1)))
  double se_error = kNaN;   // statistical uncertainty of se: se / sqrt(2 (n - 1))
};

struct BlockSweep {
  std::vector<BlockLevel> levels;  // every level with at least 2 blocks, smallest block first
  std::size_t usable = 0;          // levels[0, usable) have at least min_blocks blocks
  int optimal = -1;                // index of the Lee-Needs-Drummond level among the usable ones; -1: none
  bool plateau = false;            // the optimal level exists and no larger usable level exceeds it (see above)
  Estimate se;                     // value: the SE at the plateau, se: its uncertainty; undefined (with the
                                   // reason) otherwise
  double lower_bound = kNaN;       // not estimable: the largest SE among the usable levels (the SE is at least this)
};

// The block sweep of the mean of x (records in order). min_blocks: the fewest blocks a level may have to be used.
BlockSweep block_sweep(const std::vector<double>& x, std::size_t min_blocks = 16);

struct AutocorrelationTime {
  double tau = kNaN;         // integrated autocorrelation time, in records (1/2 for uncorrelated records)
  std::size_t window = 0;    // Sokal's window M (records); 0 when none was found
  double tau_error = kNaN;   // Madras-Sokal: tau sqrt(2 (2 M + 1) / N)
  Estimate se;               // value: the SE of the mean, sqrt(2 tau C(0) / N), se: its uncertainty (from
                             // tau_error); undefined with the reason when not estimable
};

// Sokal's automatic windowing with constant c; the SE is undefined when the series holds fewer than
// min_length tau records or no window M < N / 2 satisfies M >= c tau(M).
AutocorrelationTime autocorrelation_time(const std::vector<double>& x, double c = 6.0, double min_length = 100.0);

// The SE of a group's time average from its realizations (one series per run over its window).
struct MeanError {
  Estimate se;                  // the SE the statistic carries (rule below); undefined value means "not estimable"
  std::string rule;             // which estimator gave `se`, or why none could, in words
  double lower_bound = kNaN;    // when se is not estimable: what the estimators found it to be at least
  // Within-run estimators, combined over the R runs as sqrt(sum_r SE_r^2) / R (the SE of the mean of the run means).
  Estimate block;               // block sweep at the plateau (undefined unless every run has one)
  double block_length = kNaN;   // strain per block at the plateau (mean over the runs)
  double block_lower_bound = kNaN;
  Estimate tau;                 // from the integrated autocorrelation time (undefined unless every run has one)
  double tau_int = kNaN;        // strain (mean over the runs)
  Estimate seeds;               // across realizations: std of the run means / sqrt(R) (R >= 2)
  std::size_t runs = 0;
  // The block sweep combined over the runs at the levels all of them have: block length in strain (block records x
  // mean spacing), sqrt(sum_r SE_r^2) / R and its uncertainty; the first sweep_usable levels have >= 16 blocks.
  std::vector<double> sweep_length, sweep_se, sweep_se_error;
  std::size_t sweep_usable = 0;
};

// series[r]: run r's per-record values over its window; spacing[r]: its mean record spacing in strain (to express
// block lengths and tau in strain). Rule: one run: the plateau block SE, or the larger of it and the autocorrelation
// SE when both are estimable; not estimable when the block SE is not. Several runs: the larger of the within-run SE
// and the spread of the run means, or the spread alone (flagged) when the within-run SE is not estimable.
MeanError mean_error(const std::vector<std::vector<double>>& series, const std::vector<double>& spacing);

// The steadiness test of docs/analysis.md §3: the mean over each half of the window with its SE, and the verdict
// "steady" when |second - first| <= 2 sqrt(se1^2 + se2^2).
struct HalvesTest {
  Estimate first, second;       // means over the first and the second half of the window, with SEs
  double difference = kNaN;     // second - first
  double z = kNaN;              // difference / sqrt(se1^2 + se2^2)
  std::string verdict;          // "steady", "not steady", or "not judged: <why>"
  bool steady = false;
};
HalvesTest halves_test(const Estimate& first, const Estimate& second);

}  // namespace capsflow::analysis
