#pragma once
// Steady state of pinned capsules (D10, docs/method.md §4): the run may stop once every capsule's wall-normal
// velocity U_y and deformation D change by less than max(rtol |value|, atol) per strain unit, with a floor atol of
// each value's own units (U_y and D differ by orders of magnitude near the centreline: U_y ~ 1e-8, D ~ 1e-4). The
// rate is the least-squares slope over the records of the last `window` strain units (a slope over a window, not a
// difference of two records, so the record-to-record jitter of the global solve does not decide it).
#include <deque>
#include <string>
#include <utility>
#include <vector>

namespace capsflow {

class SteadyStateMonitor {
 public:
  // atol: the absolute floor of each monitored value (their count fixes how many values every record has).
  SteadyStateMonitor(double window, double rtol, std::vector<double> atol)
      : window_(window), rtol_(rtol), atol_(std::move(atol)) {}
  // One record: the time and the monitored values (as many as atol has).
  void add(double t, const std::vector<double>& values);
  // True when the records span the window and every value's slope is below its tolerance. `worst` (optional)
  // receives "value i: slope s, tolerance tol" of the value closest to failing.
  bool steady(std::string* worst = nullptr) const;

 private:
  double window_, rtol_;
  std::vector<double> atol_;
  std::deque<double> t_;
  std::deque<std::vector<double>> v_;
};

}  // namespace capsflow
