#pragma once
// Simulation: the time integration of a capsule suspension in the slit (docs/method.md §4, §3-4; decisions D1, D5,
// D8, D10). Physics only: no files, no printing (run_driver.hpp does the output, progress and restarts).
//
// A thin orchestrator over named parts, each in its own file and each taking its inputs explicitly (HOOMD-blue's
// Integrator with its force computes and constraints; Mirheo's plugin hooks). It owns the state, the node arrays
// and their StepWorkspace, and hands them to the parts:
//   force_terms      ElasticForce, BendingForce: F, A, f at x^n; each term its own step limit;
//   velocity_model   u^n = u_inf + S[f] (+ the interface solve at lambda != 1, drops' normal motion, the volume
//                    projection of [capsules] velocity_projection, D11);
//   step_rule        dt_n (docs/method.md section 4.1; the one home of the formula, shared with the dry run);
//   ab2_integrator   x^{n+1} = x^n + dt_n [(1 + r/2) u^n - (r/2) u^{n-1}], r = dt_n / dt_{n-1} (Euler first);
//   constraints      volume correction, contact control to min_gap (events), pins and periodic wrap; then the stop
//                    rules (StepCheck hooks);
//   flow_diagnostics the k = 0 flow rate and relative viscosity, species profiles, the record's tally.
//
// One step, from the positions x^n:
//   evaluate(): forces (each term in order) -> velocities (the model) -> the volume-averaged capsule velocities U^n
//               (cached until the positions change). The projected u^n is what the surface moves with: the AB2
//               history, the output's velocities.
//   advance():  plan (finite velocities, the rule, [time] dt_floor), then save x^n, update, constraints, checks,
//               commit. The new positions are checked before they are kept: a non-finite value, a node outside the
//               slit, an element too large for the box's cutoff condition or a contact control that did not converge
//               leaves the state at x^n and returns a stop reason, so the caller's final checkpoint is the last good
//               state.
//
// Units (D1): lengths in a's unit, time in strain units 1/gammadot (gammadot = [flow] shear_rate). The shear
// modulus of a capsule of species s is Gs = mu gammadot a / Ca_s.
//
// Determinism: with the same backend, thread count and build, a simulation restored from snapshot() continues
// bit for bit as the uninterrupted one (every kernel has a fixed summation order; FFTW is planned with
// FFTW_ESTIMATE).
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "host/physics/ab2_integrator.hpp"
#include "host/physics/config.hpp"
#include "host/physics/constraints.hpp"
#include "host/physics/contact.hpp"
#include "host/physics/flow_diagnostics.hpp"
#include "host/physics/force_terms.hpp"
#include "host/physics/initial_conditions.hpp"
#include "host/physics/step_records.hpp"
#include "host/physics/step_rule.hpp"
#include "host/physics/velocity_model.hpp"
#include "host/state/capsule_state.hpp"
#include "host/state/step_workspace.hpp"
#include "kernels/device_cells.hpp"

namespace capsflow {

class Simulation {
 public:
  // A new run: validates cfg (validate_run_config) and places the capsules (place_capsules).
  explicit Simulation(const Config& cfg);
  // Continues a run from a snapshot (the caller restores the configuration stored with it). Throws InputError
  // (prefixed by `where`) if the snapshot does not match the configuration.
  Simulation(const Config& cfg, const SimulationSnapshot& snap, const std::string& where);
  ~Simulation();

  // Forces and velocities at the current positions (no-op when already done for these positions).
  void evaluate();
  // One time step (calls evaluate() first if needed). On a stop reason the state is unchanged.
  StepInfo advance();
  // advance() in two halves. plan_step(): the next step's size and every check that can stop it before it is taken
  // (finite velocities, the step rule, [time] dt_floor), the state unchanged; advance(planned) takes that step
  // (planned.stop must be None). A run honours a stop signal between the two, so that an interrupted run's
  // checkpoint always has a next step (one whose next step fails has failed, and says so).
  StepInfo plan_step();
  StepInfo advance(StepInfo planned);
  // Why the next step cannot be taken, judged before it is (non-finite positions or velocities, a step below
  // [time] dt_floor or not finite, a step that would move a node farther than the slit height H); "" when it can.
  // A run asks before it writes any file, so that values that pass each key's range but not together (cfl 1e300,
  // Ca 1e-300, a damaged checkpoint) are refused as input, not stopped at step 0. Leaves the state unchanged.
  std::string next_step_problem();

  // Adds a stop rule (constraints.hpp's StepCheck) after the standard ones: it judges every step's new positions
  // before they are kept, and a reason other than None refuses the step with the state left at x^n, as the built-in
  // rules do (Mirheo's plugin hook: a new rule is an entry, not a branch in take_step).
  void add_step_check(StepCheck check) { checks_.push_back(std::move(check)); }

  // The complete state for a bit-identical continuation (each part adds its own pieces).
  SimulationSnapshot snapshot() const;

  const Config& config() const { return cfg_; }
  // The capsule state with host-valid node positions (on the device backend this pulls them if a kernel has moved
  // them since). Its forces and densities are host-valid only after flow_diagnostics(): the device step keeps them
  // on the device.
  const CapsuleState& state() const;
  double time() const { return time_; }         // strain units
  std::int64_t step() const { return step_; }
  double last_dt() const { return integrator_.dt_previous(); }  // 0 before the first step

  // The parts, for probes, diagnostics and tests that drive or read one of them.
  const TimeStepRule& step_rule() const { return rule_; }
  const VelocityModel& velocity_model() const { return model_; }
  const std::vector<std::unique_ptr<ForceTerm>>& force_terms() const { return forces_; }

  double ca_step() const { return rule_.ca_ref(); }  // Ca_ref of the time-step rule (D8, with the law and size factors)
  long total_contact_corrections() const { return contact_.corrections(); }
  long steps_with_contacts() const { return contact_.steps_with_contacts(); }
  long unconverged_contacts() const { return contact_.unconverged(); }
  long total_contact_events() const { return contact_.events(); }
  // The steps since the last mark_record() (the driver marks each record): the largest dt_n / dt_{n-1} (0 before
  // the second step), their count by what set their size (index: StepLimit), their interface solves.
  double max_step_ratio_since_record() const { return tally_.max_ratio; }
  const std::array<std::int64_t, kStepLimitCount>& step_limits_since_record() const { return tally_.limits; }
  void mark_record() { tally_.mark(); }
  using GmresRecordStats = capsflow::GmresRecordStats;
  const GmresRecordStats& gmres_since_record() const { return tally_.gmres; }
  // The interface-velocity solve (a species with viscosity_ratio != 1): whether the run has one, the last result.
  bool solves_interface_velocity() const { return model_.solves_interface_velocity(); }
  const GmresResult& last_gmres() const { return model_.last_gmres(); }
  // Contact events of the steps since the last call.
  std::vector<ContactEventRecord> take_events() { return contact_.take_events(); }

  // Valid after evaluate(): bulk diagnostics from the force density (FlowDiagnostics).
  FlowDiagnostics flow_diagnostics() const;
  // Interior volume of each species' capsules in `bins` equal slabs of [0, H]: [species][bin], row-major.
  std::vector<double> species_profile(int bins) const;

  // Valid after evaluate(): node velocities u^n and per capsule (3 each) the volume-averaged velocity and mean
  // rotation (physical units: length / time).
  // On the device backend each accessor pulls its array once after the step that changed it (StepWorkspace).
  const std::vector<double>& ux() const { return host_valid(ux_); }
  const std::vector<double>& uy() const { return host_valid(uy_); }
  const std::vector<double>& uz() const { return host_valid(uz_); }
  const std::vector<double>& capsule_velocity() const { return host_valid(U_); }
  bool evaluated() const { return evaluated_; }

  // Geometry at the current positions (serial-identical on every backend). Computed once per positions and shared
  // with the step rule, which reads the same geometry at the start of the next step.
  CapsuleGeometry geometry() const;
  // Centroids with the periodic shifts undone (3 per capsule): continuous trajectories.
  std::vector<double> unwrapped_centroids(const CapsuleGeometry& g) const { return pins_->unwrapped(g.centroid); }
  const std::vector<CapsulePlacement>& placements() const { return placements_; }
  const std::vector<char>& pinned() const { return pins_->pinned(); }
  // Volume of each capsule at the start of the run (the target of [capsules] volume_correction).
  const std::vector<double>& initial_volumes() const { return volume_->target(); }

  // The membrane rule's gap view of the current state (valid after evaluate()): closest pair and wall gaps below
  // h_e and the shortest time to close one (contact.hpp's closing_limits with range h_e, floor min_gap).
  ClosingLimits closing_limits() const;
  // h_e: the mean edge of the initial capsule mesh, the range below which a gap counts as near contact.
  double near_contact_range() const { return rule_.near_contact_range(); }
  // Valid after evaluate(): the AB2 truncation proxy (5/12) dt max_i |u^n - 2 u^(n-1) + u^(n-2)| (length units;
  // dt the last step), NaN before two steps of history.
  double ab2_error_proxy() const;
  // Probe support (stability_probe.hpp): the projected node velocities at positions x (3 per node, interleaved),
  // leaving the state as it was. Host backends only.
  void velocities_at(const std::vector<double>& x, std::vector<double>& u);
  // The fluid velocity at points of the slit from the state's membrane load, by the velocity operator itself
  // (VelocityModel::velocities_at; `capsflow flow`): evaluates first. target_node[p] the node point p is, or -1;
  // capsule (nullable) gets the capsule each point lies in, or -1. Host backends only.
  void fluid_velocity_at(std::size_t nt, const double* tx, const double* ty, const double* tz, const int* target_node,
                         double* ux, double* uy, double* uz, int* capsule);
  // Probe support: the node positions, 3 per node, interleaved (the layout set_positions takes).
  std::vector<double> positions() const;
  // Probe support: overwrite the node positions (3 per node, interleaved); the history is kept.
  void set_positions(const std::vector<double>& x);
  // Probe support: one step of exactly dt (strain units), no rule, no ratio cap; otherwise as advance().
  StepInfo advance_fixed(double dt);

  // Smallest node-node distance (own capsule: shortest edge; other capsules: nodes within range, min image).
  // Returns h and sets `between` when it came from two capsules (step_rule.hpp's min_node_distance).
  double min_node_distance(bool* between = nullptr) const;

  const SimulationTimings& last_timings() const { return timings_; }
  // The velocity operator S (its geometry is the state's after the last evaluate()) and its grid.
  const SingleLayerPlan& velocity_operator() const { return model_.single_layer(); }
  const GgemGrid& grid() const { return model_.single_layer().grid(); }
  // The owner of the device copies and their transfer counts (inactive, zero transfers, off the device backend).
  const StepWorkspace& workspace() const { return *ws_; }

 private:
  void build_state();
  void attach_workspace();
  const std::vector<double>& host_valid(const std::vector<double>& v) const {
    ws_->host_read(v);
    return v;
  }
  // Serial on the host backends (the reference sums of geometry(), as before), Device on the device.
  Backend geometry_backend() const { return cfg_.run.backend == Backend::Device ? Backend::Device : Backend::Serial; }
  NodeVectors uvec() { return {ux_, uy_, uz_}; }
  NodeVectors wvec() { return {wx_, wy_, wz_}; }
  void choose_step(StepInfo& info);
  // closing_limits() at the given centroids (the current geometry's).
  ClosingLimits closing_limits_at(const std::vector<double>& centroid) const;
  // The geometry at the current positions on backend b, computed once per positions (the step rule, the record's
  // series and the gap diagnostics read one copy); and the closing limits at the current positions and velocities.
  const CapsuleGeometry& current_geometry(Backend b) const;
  void positions_changed();  // drops both caches and the evaluated velocities
  StepInfo take_step(StepInfo info);

  Config cfg_;
  std::vector<CapsulePlacement> placements_;
  CapsuleState s_;
  // The parts (in the order a step uses them).
  std::vector<std::unique_ptr<ForceTerm>> forces_;
  VelocityModel model_;
  TimeStepRule rule_;
  Ab2Integrator integrator_;
  std::unique_ptr<VolumeCorrection> volume_;  // always made (its targets are a diagnostic); applied when configured
  ContactControl contact_;
  std::unique_ptr<PinAndWrap> pins_;
  std::vector<Constraint*> constraints_;      // in their order: volume (if configured), contact, pins and wrap
  std::vector<StepCheck> checks_;             // the stop rules, in order
  RecordTally tally_;

  double time_ = 0.0;
  std::int64_t step_ = 0;
  bool evaluated_ = false;
  mutable CapsuleGeometry geometry_cache_;
  mutable bool geometry_cached_ = false;
  mutable Backend geometry_cache_backend_ = Backend::Serial;
  mutable ClosingLimits closing_cache_;
  mutable bool closing_cached_ = false;
  std::vector<double> ux_, uy_, uz_, U_, omega_;
  std::vector<double> wx_, wy_, wz_;  // volume gradients and normals (velocity projection, drops, volume correction)
  SimulationTimings timings_;
  // Device copies of the arrays above (no-op off the device backend). Through a pointer so that const accessors
  // can pull (HOOMD's host access of a device-valid array), as const methods of a cache may fill it.
  std::unique_ptr<StepWorkspace> ws_;
  // Device backend: the step-size rule's node cell list, binned and searched on the device (kernels/device_cells).
  std::unique_ptr<DeviceNodeCells> node_cells_;
};

}  // namespace capsflow
