#pragma once
// The integrator: variable-step Adams-Bashforth 2 (docs/method.md §4),
//   x^{n+1} = x^n + dt_n / gammadot [(1 + r/2) u^n - (r/2) u^{n-1}],  r = dt_n / dt_{n-1}  (forward Euler first),
// with its history u^{n-1}, u^{n-2} (the second only for the truncation proxy), dt_{n-1}, and x^n saved while a step
// is tried so that a refused step leaves the state where it was. Takes the state, the workspace and the velocities
// explicitly (HOOMD's IntegrationMethod); a second integrator (semi-implicit bending) would take its place.
//
//   integrator.save(s, ws);                 // x^n
//   integrator.update(s, ws, dt, u);        // x^{n+1}
//   ... constraints, checks; on a stop: integrator.restore(s, ws);
//   integrator.commit(ws, u, dt);           // u^{n-2} <- u^{n-1} <- u^n
#include <cstddef>
#include <vector>

#include "host/physics/step_records.hpp"
#include "host/state/capsule_state.hpp"
#include "host/state/step_workspace.hpp"

namespace capsflow {

class Ab2Integrator {
 public:
  Ab2Integrator(Backend backend, double shear_rate) : backend_(backend), shear_rate_(shear_rate) {}

  // n nodes, no history (the history arrays at their final size: the workspace keys them by buffer).
  void reset(std::size_t n);
  // The arrays the workspace registers (u^{n-1}, u^{n-2}, the saved x^n), in its order.
  NodeVectors previous() { return {up_[0], up_[1], up_[2]}; }
  NodeVectors previous2() { return {upp_[0], upp_[1], upp_[2]}; }
  NodeVectors saved() { return {xs_[0], xs_[1], xs_[2]}; }

  bool have_history() const { return have_history_; }
  double dt_previous() const { return dt_prev_; }
  // The weights a, b of u^n and u^{n-1} for a step dt (strain units): 1, 0 without history.
  void weights(double dt, double& a, double& b) const;

  void save(CapsuleState& s, StepWorkspace& ws);     // x^n into the saved arrays
  void update(CapsuleState& s, StepWorkspace& ws, double dt, NodeVectors u);  // x^{n+1} in place
  void restore(CapsuleState& s, StepWorkspace& ws);  // back to the saved x^n (a refused step)
  // The step dt is kept: u^{n-2} <- u^{n-1} <- u^n (u then holds stale values until the next evaluation).
  void commit(StepWorkspace& ws, NodeVectors u, double dt);

  // The largest node displacement of a step dt (length units; host), for the refusal of a step larger than the slit.
  double max_move(StepWorkspace& ws, double dt, NodeVectors u);
  // The AB2 truncation proxy (5/12) dt max_i |u^n - 2 u^(n-1) + u^(n-2)| (length units; dt the last step), NaN
  // before two steps of history.
  double error_proxy(StepWorkspace& ws, const std::vector<double>& ux, const std::vector<double>& uy,
                     const std::vector<double>& uz) const;

  void save(SimulationSnapshot& st, StepWorkspace& ws) const;  // history and dt_{n-1}
  void restore(const SimulationSnapshot& st);                  // after reset(); sizes checked by the caller

 private:
  Backend backend_;
  double shear_rate_;
  std::vector<double> up_[3], upp_[3], xs_[3];  // u^{n-1}, u^{n-2}, saved x^n
  bool have_history_ = false, have_history2_ = false;
  double dt_prev_ = 0.0;
};

}  // namespace capsflow
