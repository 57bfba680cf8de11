#pragma once
// Simulation: the time integration of a capsule suspension in the slit (method-spec 8, 9.3, 10; decisions D1, D5,
// D8, D10). Physics only: no files, no printing (run_driver.hpp does the output, progress and restarts).
//
// One step, from the positions x^n:
//   evaluate(): membrane forces -> node velocities u^n (CapsuleVelocitySolver: u_inf + local + global) and the
//               volume-averaged capsule velocities U^n (cached until the positions change).
//   advance():  dt_n = cfl * Ca_min * h^n (h: smallest node-node distance, own capsule or another, D8);
//               x^{n+1} = x^n + dt_n [(1 + r/2) u^n - (r/2) u^{n-1}], r = dt_n / dt_{n-1} (forward Euler first);
//               rigid contact control to min_gap (pairs and walls, D5); optionally ([capsules] volume_correction,
//               D11) each capsule's volume restored by a uniform normal displacement; pinned capsules translated back to their
//               centre of mass at the start (D10); capsules whose node mean left [0, Lx) x [0, Lz) shifted by a
//               period (their image count keeps the unwrapped trajectory).
//   The new positions are checked before they are kept: a non-finite value, a node outside the slit, an element
//   too large for the box's cutoff condition or a step below [time] dt_floor leaves the state at x^n and returns a stop reason, so the caller's final checkpoint is
//   the last good state.
//
// Units (D1): lengths in a's unit, time in strain units 1/gammadot (gammadot = [flow] shear_rate). The shear
// modulus of a capsule of species s is Gs = mu gammadot a / Ca_s.
//
// Determinism: with the same backend, thread count and build, a simulation restored from write_state() continues
// bit for bit as the uninterrupted one (every kernel has a fixed summation order; FFTW is planned with
// FFTW_ESTIMATE).
#include <cstdint>
#include <string>
#include <vector>

#include "host/capsule_state.hpp"
#include "host/capsule_velocity.hpp"
#include "host/config.hpp"
#include "host/contact.hpp"
#include "host/initial_conditions.hpp"

namespace capsflow {

class H5File;

enum class StopReason { None, NotFinite, LeftSlit, DtBelowFloor, MeshTooLarge };
const char* stop_reason_name(StopReason r);

struct StepInfo {
  StopReason stop = StopReason::None;
  std::string message;           // why it stopped (empty when it did not)
  double dt = 0.0;               // strain units; the step taken (or refused)
  double h = 0.0;                // node-node distance that set dt
  bool h_between_capsules = false;  // h came from two different capsules
  ContactStats contact;          // this step's contact control
};

struct SimulationTimings {        // seconds of the last evaluate() / advance()
  double forces = 0.0, local_nodes = 0.0, local_walls = 0.0, global = 0.0, velocity_total = 0.0;
  double step_size = 0.0, update = 0.0, contact = 0.0;
  SimulationTimings& operator+=(const SimulationTimings& o) {  // summing over steps (run summary, benchmark)
    forces += o.forces;
    local_nodes += o.local_nodes;
    local_walls += o.local_walls;
    global += o.global;
    velocity_total += o.velocity_total;
    step_size += o.step_size;
    update += o.update;
    contact += o.contact;
    return *this;
  }
};

class Simulation {
 public:
  // A new run: validates cfg (validate_run_config) and places the capsules (place_capsules).
  explicit Simulation(const Config& cfg);
  // Continues a run from the /state group written by write_state (the caller parses the configuration stored
  // in the checkpoint). Throws InputError if the checkpoint does not match the configuration.
  Simulation(const Config& cfg, const H5File& checkpoint);

  // Forces and velocities at the current positions (no-op when already done for these positions).
  void evaluate();
  // One time step (calls evaluate() first if needed). On a stop reason the state is unchanged.
  StepInfo advance();

  // The complete state for a bit-identical continuation, under /state of `f`.
  void write_state(H5File& f) const;

  const Config& config() const { return cfg_; }
  const CapsuleState& state() const { return s_; }
  double time() const { return time_; }         // strain units
  std::int64_t step() const { return step_; }
  double last_dt() const { return dt_prev_; }  // 0 before the first step
  double ca_min() const { return ca_min_; }
  long total_contact_corrections() const { return contact_corrections_; }
  long steps_with_contacts() const { return steps_with_contacts_; }
  long unconverged_contacts() const { return unconverged_contacts_; }

  // Valid after evaluate(): node velocities u^n and per capsule (3 each) the volume-averaged velocity and mean
  // rotation (physical units: length / time).
  const std::vector<double>& ux() const { return ux_; }
  const std::vector<double>& uy() const { return uy_; }
  const std::vector<double>& uz() const { return uz_; }
  const std::vector<double>& capsule_velocity() const { return U_; }
  bool evaluated() const { return evaluated_; }

  // Geometry at the current positions (computed on demand, serial-identical on every backend).
  CapsuleGeometry geometry() const;
  // Centroids with the periodic shifts undone (3 per capsule): continuous trajectories.
  std::vector<double> unwrapped_centroids(const CapsuleGeometry& g) const;
  const std::vector<CapsulePlacement>& placements() const { return placements_; }
  const std::vector<char>& pinned() const { return pinned_; }

  // Smallest node-node distance (own capsule: shortest edge; other capsules: nodes within range, min image).
  // Returns h and sets `between` when it came from two capsules.
  double min_node_distance(bool* between = nullptr) const;

  const SimulationTimings& last_timings() const { return timings_; }
  const CapsuleVelocitySolver& velocity_solver() const { return velocity_; }

 private:
  void build_state();
  void pin_and_wrap();
  void correct_volumes();

  Config cfg_;
  std::vector<CapsulePlacement> placements_;
  CapsuleState s_;
  CapsuleVelocitySolver velocity_;
  double ca_min_ = 0.0;
  std::vector<char> pinned_;
  std::vector<double> pin_centre_;     // 3 per capsule (pinned ones)
  std::vector<std::int64_t> image_;    // 2 per capsule: periods shifted in x and z
  std::vector<double> volume0_;        // initial volume per capsule ([capsules] volume_correction)

  double time_ = 0.0;
  std::int64_t step_ = 0;
  double dt_prev_ = 0.0;
  bool have_history_ = false;
  std::vector<double> uxp_, uyp_, uzp_;  // u^{n-1}
  long contact_corrections_ = 0, steps_with_contacts_ = 0, unconverged_contacts_ = 0;

  bool evaluated_ = false;
  std::vector<double> ux_, uy_, uz_, U_, omega_;
  std::vector<double> xs_, ys_, zs_;  // saved x^n while a step is tried
  SimulationTimings timings_;
};

}  // namespace capsflow
