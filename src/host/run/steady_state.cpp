// The implementation of steady_state.hpp: the steady state of pinned capsules (D10, docs/method.md 4).
#include "host/run/steady_state.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace capsflow {

void SteadyStateMonitor::add(double t, const std::vector<double>& values) {
  if (values.size() != atol_.size()) throw std::invalid_argument("SteadyStateMonitor: value count differs from atol");
  t_.push_back(t);
  v_.push_back(values);
  // Keep the records within the window (plus the one just before it, so the span can reach the window).
  while (t_.size() > 2 && t_[1] <= t - window_) {
    t_.pop_front();
    v_.pop_front();
  }
}

bool SteadyStateMonitor::steady(std::string* worst) const {
  const std::size_t n = t_.size();
  if (n < 5 || t_.back() - t_.front() < window_ * (1.0 - 1e-9)) {
    if (worst) *worst = "window not yet covered";
    return false;
  }
  double tm = 0.0;
  for (double t : t_) tm += t;
  tm /= static_cast<double>(n);
  double stt = 0.0;
  for (double t : t_) stt += (t - tm) * (t - tm);
  const std::size_t nv = v_.front().size();
  double worst_ratio = 0.0;
  for (std::size_t i = 0; i < nv; ++i) {
    double vm = 0.0;
    for (const auto& v : v_) vm += v[i];
    vm /= static_cast<double>(n);
    double stv = 0.0;
    for (std::size_t r = 0; r < n; ++r) stv += (t_[r] - tm) * (v_[r][i] - vm);
    const double slope = stv / stt, tol = std::max(rtol_ * std::abs(vm), atol_[i]);
    const double ratio = std::abs(slope) / tol;
    if (!(ratio <= worst_ratio) && worst) {  // also catches NaN
      char buf[160];
      std::snprintf(buf, sizeof buf, "value %zu: slope %.3g per strain, tolerance %.3g", i, slope, tol);
      *worst = buf;
    }
    if (!(ratio <= worst_ratio)) worst_ratio = std::isnan(ratio) ? INFINITY : ratio;
  }
  return worst_ratio < 1.0;
}

}  // namespace capsflow
