// The implementation of ab2_integrator.hpp: the variable-step Adams-Bashforth 2 integrator and its history.
#include "host/physics/ab2_integrator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "kernels/step_update.hpp"

namespace capsflow {

void Ab2Integrator::reset(std::size_t n) {
  for (auto* v : {&up_, &upp_})
    for (auto& c : *v) c.assign(n, 0.0);
  for (auto& c : xs_) c.resize(n);
  have_history_ = have_history2_ = false;
  dt_prev_ = 0.0;
}

void Ab2Integrator::weights(double dt, double& a, double& b) const {
  a = 1.0;
  b = 0.0;
  if (have_history_) {
    const double r = dt / dt_prev_;
    a = 1.0 + 0.5 * r;
    b = -0.5 * r;
  }
}

void Ab2Integrator::save(CapsuleState& s, StepWorkspace& ws) {
  for (auto& v : xs_) ws.device_overwrite(v);
  copy3(backend_, s.x.size(), s.x.data(), s.y.data(), s.z.data(), xs_[0].data(), xs_[1].data(), xs_[2].data());
}

void Ab2Integrator::update(CapsuleState& s, StepWorkspace& ws, double dt, NodeVectors u) {
  // Physical time step dt / gammadot.
  const double dtp = dt / shear_rate_;
  double a, b;
  weights(dt, a, b);
  for (auto& v : up_) ws.device_read(v);
  for (auto* v : {&s.x, &s.y, &s.z}) ws.device_write(*v);
  ab2_update(backend_, s.x.size(), dtp, a, b, u.x.data(), u.y.data(), u.z.data(), up_[0].data(), up_[1].data(),
             up_[2].data(), s.x.data(), s.y.data(), s.z.data());
}

void Ab2Integrator::restore(CapsuleState& s, StepWorkspace& ws) {
  ws.swap(s.x, xs_[0]);
  ws.swap(s.y, xs_[1]);
  ws.swap(s.z, xs_[2]);
}

void Ab2Integrator::commit(StepWorkspace& ws, NodeVectors u, double dt) {
  for (int c = 0; c < 3; ++c) ws.swap(upp_[c], up_[c]);
  ws.swap(up_[0], u.x);
  ws.swap(up_[1], u.y);
  ws.swap(up_[2], u.z);
  have_history2_ = have_history_;
  have_history_ = true;
  dt_prev_ = dt;
}

double Ab2Integrator::max_move(StepWorkspace& ws, double dt, NodeVectors u) {
  // The step moves node i by dt (a u^n + b u^(n-1)) / gammadot (AB2; Euler on the first step).
  double a, b;
  weights(dt, a, b);
  for (auto* v : {&u.x, &u.y, &u.z, &up_[0], &up_[1], &up_[2]}) ws.host_read(*v);
  double move = 0.0;
  for (std::size_t i = 0; i < u.x.size(); ++i) {
    const double dx = a * u.x[i] + b * up_[0][i], dy = a * u.y[i] + b * up_[1][i], dz = a * u.z[i] + b * up_[2][i];
    move = std::max(move, std::sqrt(dx * dx + dy * dy + dz * dz));
  }
  return move * (dt / shear_rate_);
}

double Ab2Integrator::error_proxy(StepWorkspace& ws, const std::vector<double>& ux, const std::vector<double>& uy,
                                  const std::vector<double>& uz) const {
  if (!have_history2_) return std::numeric_limits<double>::quiet_NaN();
  for (const auto* v : {&ux, &uy, &uz, &up_[0], &up_[1], &up_[2], &upp_[0], &upp_[1], &upp_[2]}) ws.device_read(*v);
  ws.note_scalar_results(1);
  const double d2 = max_second_difference(backend_, ux.size(), ux.data(), uy.data(), uz.data(), up_[0].data(),
                                          up_[1].data(), up_[2].data(), upp_[0].data(), upp_[1].data(),
                                          upp_[2].data());
  return 5.0 / 12.0 * (dt_prev_ / shear_rate_) * d2;
}

void Ab2Integrator::save(SimulationSnapshot& st, StepWorkspace& ws) const {
  for (const auto* v : {&up_, &upp_})
    for (const auto& c : *v) ws.host_read(c);
  const std::size_t n = up_[0].size();
  st.u_previous.resize(3 * n);
  st.u_previous2.resize(3 * n);
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) {
      st.u_previous[3 * i + c] = up_[c][i];
      st.u_previous2[3 * i + c] = upp_[c][i];
    }
  st.dt_previous = dt_prev_;
  st.have_history = have_history_;
  st.have_history2 = have_history2_;
}

void Ab2Integrator::restore(const SimulationSnapshot& st) {
  const std::size_t n = up_[0].size();
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) up_[c][i] = st.u_previous[3 * i + c];
  if (st.have_history2 && st.u_previous2.size() == 3 * n) {
    for (std::size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) upp_[c][i] = st.u_previous2[3 * i + c];
    have_history2_ = true;
  }
  dt_prev_ = st.dt_previous;
  have_history_ = st.have_history;
}

}  // namespace capsflow
