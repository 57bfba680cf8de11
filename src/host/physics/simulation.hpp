#pragma once
// Simulation: the time integration of a capsule suspension in the slit (method-spec 8, 9.3, 10; decisions D1, D5,
// D8, D10). Physics only: no files, no printing (run_driver.hpp does the output, progress and restarts).
//
// One step, from the positions x^n:
//   evaluate(): membrane forces -> node velocities u^n = u_inf + S[f] (SingleLayerPlan: set_geometry, apply), projected
//               per capsule to zero discrete volume rate ([capsules] velocity_projection, D11) -> the
//               volume-averaged capsule velocities U^n (cached until the positions change). The projected u^n is
//               what the surface moves with: the AB2 history, the output's velocities.
//   advance():  dt_n by [time] step_rule (docs/method.md section 4.1; Ca_ref the smallest over the capsules of
//               Ca (a_ref / a) / f, f the law's stiffness factor step_stiffness_factor and a_ref the [capsules]
//               radius (Ca itself for neo-Hookean capsules of one size), or [time] reference_ca times the same
//               factors, D8):
//                 membrane: dt_M = cfl * Ca_ref * h / a_ref (Config::rule_step), h the shortest edge of any
//                   capsule, with bending combined
//                   harmonically with bending_cfl mu min_k h_k^3 / kappa_k (the rates add); times near_contact_factor
//                   while a capsule pair is closer than h_e (the reference mesh's mean edge); capped by the
//                   collision cap c_gap * max(g, min_gap) / w over pair and wall gaps g < h_e closing at w > 0;
//                 paper: dt = cfl * Ca_ref * h / a_ref, h the smallest node-node distance, own capsule or another;
//               then capped at max_step_ratio * dt_{n-1};
//               x^{n+1} = x^n + dt_n [(1 + r/2) u^n - (r/2) u^{n-1}], r = dt_n / dt_{n-1} (forward Euler first);
//               each capsule's volume restored by a uniform normal displacement, the safety net for the O(dt^2)
//               remainder ([capsules] volume_correction, D11); rigid contact control to min_gap (pairs and walls,
//               D5; every correction recorded as an event); pinned capsules translated back to their centre of mass
//               at the start (D10); capsules whose node mean left [0, Lx) x [0, Lz) shifted by a period (their
//               image count keeps the unwrapped trajectory).
//   The new positions are checked before they are kept: a non-finite value, a node outside the slit, an element
//   too large for the box's cutoff condition or a step below [time] dt_floor leaves the state at x^n and returns a stop reason, so the caller's final checkpoint is
//   the last good state.
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

#include "host/state/capsule_state.hpp"
#include "host/physics/config.hpp"
#include "host/physics/contact.hpp"
#include "host/physics/initial_conditions.hpp"
#include "host/solver/double_layer_plan.hpp"
#include "host/solver/gmres.hpp"
#include "host/solver/single_layer_plan.hpp"
#include "host/state/step_workspace.hpp"
#include "kernels/device_cells.hpp"

namespace capsflow {

enum class StopReason { None, NotFinite, LeftSlit, DtBelowFloor, MeshTooLarge, ContactFailed, SolveNotConverged };
const char* stop_reason_name(StopReason r);

// One contact correction (contact.hpp's ContactEvent with the time of the step that made it).
struct ContactEventRecord {
  double time = 0.0;          // strain at the end of the step
  int p = 0, q = 0;           // capsules; a wall correction has q = -1 (wall y = 0) or -2 (wall y = H)
  double gap_before = 0.0;    // signed gap when first detected in the step
  double dy_p = 0.0, dy_q = 0.0;  // y-displacement of p and q by this correction (0 for the wall)
};

// Bulk diagnostics from the membrane force density at the current state (docs/method.md section 4.5): exact for
// the k = 0 (plane-averaged) flow of forces between two no-slip walls, with the force density linear on flat
// elements as the single layer uses it. NaN where the flow type does not define it.
struct FlowDiagnostics {
  double flow_rate_ratio = 0.0;     // Poiseuille at fixed pressure drop: Q / Q_0 = 1 + 3 M2 / (mu A gammadot_w H^2)
                                    // (lambda != 1: M2 also counts the inner fluid's flux, docs/method.md 4.5)
  double relative_viscosity = 0.0;  // shear: wall shear stress / mu gammadot = 1 - M1 / (mu gammadot A H)
};

// From the force density s.fx (valid after the membrane forces are computed) and positions of s. With a viscosity
// ratio other than 1, interface_velocity (the interface equation's solution at these positions, [x..., y..., z...])
// and lambda (per capsule) add the double layer's force dipoles mu (1 - lambda) (u n + n u) dS and, to the flow
// rate, the inner fluid's (1 - lambda) int_V u_x dV (the representation is lambda u inside a capsule, a
// cross-section's flux counts u there once); empty: forces only.
FlowDiagnostics flow_diagnostics(const CapsuleState& s, const Config& cfg,
                                 const std::vector<double>& interface_velocity = {},
                                 const std::vector<double>& lambda = {});

// What set a step's size (the /series/step_limit codes, docs/output_format.md).
enum class StepLimit : int {
  Membrane = 0,     // membrane rule: cfl Ca_ref h with h the shortest edge (paper rule: h inside a capsule)
  NearContact = 1,  // membrane rule times near_contact_factor < 1 (a pair closer than h_e)
  Collision = 2,    // the collision cap
  Ratio = 3,        // max_step_ratio * dt_{n-1}
  PaperGap = 4,     // paper rule with h between two capsules
};
inline constexpr int kStepLimitCount = 5;
const char* step_limit_name(StepLimit l);

struct StepInfo {
  StopReason stop = StopReason::None;
  std::string message;           // why it stopped (empty when it did not)
  double dt = 0.0;               // strain units; the step taken (or refused)
  StepLimit limit = StepLimit::Membrane;  // what set dt
  double dt_membrane = 0.0;      // membrane rule: cfl Ca_ref h / a_ref (before the near-contact factor)
  double dt_collision = 0.0;     // membrane rule: the collision cap (inf when no gap closes)
  double pair_gap = 0.0;         // membrane rule: closest capsule pair gap below h_e (inf: none)
  double h = 0.0;                // node-node distance that set dt
  double ratio = 0.0;            // dt / dt_previous (0 for the first step)
  bool capped = false;           // dt was limited by [time] max_step_ratio
  bool h_between_capsules = false;  // h came from two different capsules
  ContactStats contact;          // this step's contact control
};

struct SimulationTimings {        // seconds of the last evaluate() / advance()
  double forces = 0.0, local_nodes = 0.0, local_walls = 0.0, global = 0.0, velocity_total = 0.0;
  double step_size = 0.0, update = 0.0, contact = 0.0;
  double interface_solve = 0.0;  // viscosity ratio != 1: the GMRES solve (double-layer applications), within
                                 // velocity_total
  SimulationTimings& operator+=(const SimulationTimings& o) {  // summing over steps (run summary, benchmark)
    interface_solve += o.interface_solve;
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

// Everything beyond the configuration that a bit-identical continuation needs (checkpoint.cpp stores it under
// /state). Vectors of points are interleaved x, y, z.
struct SimulationSnapshot {
  std::vector<double> initial_centres;    // 3 per capsule: they define the reference shapes exactly
  std::vector<double> initial_orientations;  // 9 per capsule (row-major body -> lab), or empty: all the identity
  std::vector<std::int64_t> species, pinned;  // per capsule
  std::vector<double> pin_centres;        // 3 per capsule
  std::vector<std::int64_t> image;        // 2 per capsule: periods shifted in x and z
  std::vector<double> positions;          // 3 per node
  std::vector<double> u_previous;         // 3 per node: the AB2 history u^{n-1}
  std::vector<double> u_previous2;        // 3 per node: u^{n-2} (only the AB2 error proxy reads it); may be empty
  std::vector<double> interface_velocity; // viscosity ratio != 1: the first guess of the solve at these positions,
                                          // [x..., y..., z...] (the one it used when the state was evaluated);
                                          // empty otherwise
  std::vector<double> interface_velocity_previous;  // the last answer before that solve (extrapolation); may be empty
  double interface_velocity_previous_time = 0.0;    // its strain
  double time = 0.0, dt_previous = 0.0;
  std::int64_t step = 0;
  bool have_history = false;
  bool have_history2 = false;             // u_previous2 holds u^{n-2}
  std::int64_t contact_corrections = 0, steps_with_contacts = 0, unconverged_contacts = 0;
  double max_step_ratio_since_record = 0.0;
  // Interface-velocity solves since the last record (viscosity ratio != 1; zero otherwise and in older checkpoints).
  std::int64_t gmres_steps_since_record = 0, gmres_iterations_since_record = 0, gmres_max_iterations_since_record = 0;
  double gmres_max_residual_since_record = 0.0;
  std::int64_t contact_events = 0;
  std::vector<std::int64_t> step_limits_since_record;  // kStepLimitCount entries; empty in older checkpoints
};

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

  // The complete state for a bit-identical continuation.
  SimulationSnapshot snapshot() const;

  const Config& config() const { return cfg_; }
  // The capsule state with host-valid node positions (on the device backend this pulls them if a kernel has moved
  // them since). Its forces and densities are host-valid only after flow_diagnostics(): the device step keeps them
  // on the device.
  const CapsuleState& state() const;
  double time() const { return time_; }         // strain units
  std::int64_t step() const { return step_; }
  double last_dt() const { return dt_prev_; }  // 0 before the first step
  double ca_step() const { return ca_step_; }  // Ca_ref of the time-step rule (D8, with the law and size factors)
  // The bending limit of the step, [time] bending_cfl mu gammadot h^3 / kappa_max in strain units (inf without
  // bending), for the shortest edge h; and an elastic limit dt combined with it, 1 / (1/dt + 1/bending_step(h)).
  double bending_step(double h) const;
  double with_bending(double dt_elastic, double h) const;
  // The rule's bending limit: bending_cfl mu gammadot min_k h_k^3 / kappa_k over the capsules with kappa_k > 0, h_k
  // a capsule's shortest edge (one size and rigidity: bending_step(h) of the shortest edge); and combined with dt.
  double bending_step(const CapsuleGeometry& g) const;
  double with_bending(double dt_elastic, const CapsuleGeometry& g) const;
  long total_contact_corrections() const { return contact_corrections_; }
  long steps_with_contacts() const { return steps_with_contacts_; }
  long unconverged_contacts() const { return unconverged_contacts_; }
  long total_contact_events() const { return contact_events_; }
  // Largest dt_n / dt_{n-1} since the last mark_record() (0 before the second step); the driver marks each record.
  double max_step_ratio_since_record() const { return max_ratio_since_record_; }
  // Steps since the last mark_record() by what set their size (index: StepLimit).
  const std::array<std::int64_t, kStepLimitCount>& step_limits_since_record() const { return limits_since_record_; }
  void mark_record() {
    max_ratio_since_record_ = 0.0;
    limits_since_record_.fill(0);
    gmres_since_record_ = GmresRecordStats{};
  }
  // The interface-velocity solve (a species with viscosity_ratio != 1): whether the run has one, the last solve's
  // result, and the solves of the steps taken since the last mark_record() (steps, operator applications, the largest
  // count and final residual).
  struct GmresRecordStats {
    std::int64_t steps = 0, iterations = 0, max_iterations = 0;
    double max_residual = 0.0;
  };
  bool solves_interface_velocity() const { return double_layer_ != nullptr; }
  const GmresResult& last_gmres() const { return gmres_last_; }
  const GmresRecordStats& gmres_since_record() const { return gmres_since_record_; }
  // Contact events of the steps since the last call.
  std::vector<ContactEventRecord> take_events() { return std::exchange(events_, {}); }

  // Valid after evaluate(): bulk diagnostics from the force density (FlowDiagnostics).
  FlowDiagnostics flow_diagnostics() const;
  // Interior volume of each species' capsules in `bins` equal slabs of [0, H] (exact for the triangulated
  // surfaces): [species][bin], row-major.
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
  std::vector<double> unwrapped_centroids(const CapsuleGeometry& g) const;
  const std::vector<CapsulePlacement>& placements() const { return placements_; }
  const std::vector<char>& pinned() const { return pinned_; }
  // Volume of each capsule at the start of the run (the target of [capsules] volume_correction).
  const std::vector<double>& initial_volumes() const { return volume0_; }

  // The membrane rule's gap view of the current state (valid after evaluate()): closest pair and wall gaps below
  // h_e and the shortest time to close one (contact.hpp's closing_limits with range h_e, floor min_gap).
  ClosingLimits closing_limits() const;
  // h_e: the mean edge of the initial capsule mesh, the range below which a gap counts as near contact.
  double near_contact_range() const { return h_near_; }
  // Valid after evaluate(): the AB2 truncation proxy (5/12) dt max_i |u^n - 2 u^(n-1) + u^(n-2)| (length units;
  // dt the last step), NaN before two steps of history.
  double ab2_error_proxy() const;
  // Probe support (stability_probe.hpp): the projected node velocities at positions x (3 per node, interleaved),
  // leaving the state as it was. Host backends only.
  void velocities_at(const std::vector<double>& x, std::vector<double>& u);
  // Probe support: the node positions, 3 per node, interleaved (the layout set_positions takes).
  std::vector<double> positions() const;
  // Probe support: overwrite the node positions (3 per node, interleaved); the history is kept.
  void set_positions(const std::vector<double>& x);
  // Probe support: one step of exactly dt (strain units), no rule, no ratio cap; otherwise as advance().
  StepInfo advance_fixed(double dt);

  // Smallest node-node distance (own capsule: shortest edge; other capsules: nodes within range, min image).
  // Returns h and sets `between` when it came from two capsules.
  double min_node_distance(bool* between = nullptr) const;

  const SimulationTimings& last_timings() const { return timings_; }
  // The velocity operator S (its geometry is the state's after the last evaluate()) and its grid.
  const SingleLayerPlan& velocity_operator() const { return velocity_; }
  const GgemGrid& grid() const { return velocity_.grid(); }
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
  void pin_and_wrap();
  void choose_step(StepInfo& info);
  // closing_limits() at the given centroids (the current geometry's).
  ClosingLimits closing_limits_at(const std::vector<double>& centroid) const;
  // The geometry at the current positions on backend b, computed once per positions (the step rule, the record's
  // series and the gap diagnostics read one copy); and the closing limits at the current positions and velocities.
  const CapsuleGeometry& current_geometry(Backend b) const;
  void positions_changed();  // drops both caches and the evaluated velocities
  StepInfo take_step(StepInfo info);
  void correct_volumes();
  void project_velocities();
  // Viscosity ratio != 1: u from ((1 + lambda)/2) u - K~[(1 - lambda) u] = u_inf + S[f] (in ux_, uy_, uz_ on entry).
  void solve_interface_velocity();
  void make_interface_solve();  // end of build_state()
  void normal_motion_of_drops();

  Config cfg_;
  std::vector<CapsulePlacement> placements_;
  CapsuleState s_;
  SingleLayerPlan velocity_;
  std::unique_ptr<DoubleLayerPlan> double_layer_;  // only with a viscosity ratio != 1
  bool has_drops_ = false;                         // some capsule has law = "surface-tension"
  std::vector<double> lambda_;                     // viscosity ratio per capsule
  GmresResult gmres_last_;
  GmresRecordStats gmres_since_record_;
  std::vector<double> dl_q_[3], dl_k_[3], gmres_b_, gmres_x_;
  // First guesses of the interface solve (docs/method.md 3.1): the last two answers, extrapolated linearly in time.
  std::vector<double> gmres_guess_;        // the last solve's answer (blocked x, y, z)
  double gmres_guess_time_ = 0.0;          // its strain
  std::vector<double> gmres_prev_answer_;  // the answer before it (empty: none yet)
  double gmres_prev_answer_time_ = 0.0;
  std::vector<double> gmres_forced_guess_; // a restored checkpoint's guess for its first solve (then empty)
  std::vector<double> gmres_used_guess_;   // the guess the last solve started from
  // The first guess of a solve at strain t into x (3 n): false when there is none (the solve starts from its
  // right-hand side).
  bool gmres_first_guess(double t, std::vector<double>& x) const;
  double ca_step_ = 0.0;
  double kappa_max_ = 0.0;  // the largest bending rigidity of any capsule
  std::vector<char> pinned_;
  std::vector<double> pin_centre_;     // 3 per capsule (pinned ones)
  std::vector<std::int64_t> image_;    // 2 per capsule: periods shifted in x and z
  std::vector<double> volume0_;        // initial volume per capsule ([capsules] volume_correction)

  double time_ = 0.0;
  std::int64_t step_ = 0;
  double dt_prev_ = 0.0;
  bool have_history_ = false, have_history2_ = false;
  std::vector<double> uxp_, uyp_, uzp_;  // u^{n-1}
  std::vector<double> uxpp_, uypp_, uzpp_;  // u^{n-2} (AB2 error proxy only)
  double h_near_ = 0.0;                  // h_e: mean edge of the initial mesh
  long contact_corrections_ = 0, steps_with_contacts_ = 0, unconverged_contacts_ = 0, contact_events_ = 0;
  double max_ratio_since_record_ = 0.0;
  std::array<std::int64_t, kStepLimitCount> limits_since_record_{};
  std::vector<ContactEventRecord> events_;
  std::vector<double> wx_, wy_, wz_;  // volume gradients (velocity projection, volume correction)

  bool evaluated_ = false;
  mutable CapsuleGeometry geometry_cache_;
  mutable bool geometry_cached_ = false;
  mutable Backend geometry_cache_backend_ = Backend::Serial;
  mutable ClosingLimits closing_cache_;
  mutable bool closing_cached_ = false;
  std::vector<double> ux_, uy_, uz_, U_, omega_;
  std::vector<double> xs_, ys_, zs_;  // saved x^n while a step is tried
  SimulationTimings timings_;
  // Device copies of the arrays above (no-op off the device backend). Through a pointer so that const accessors
  // can pull (HOOMD's host access of a device-valid array), as const methods of a cache may fill it.
  std::unique_ptr<StepWorkspace> ws_;
  // Device backend: the step-size rule's node cell list, binned and searched on the device (kernels/device_cells).
  std::unique_ptr<DeviceNodeCells> node_cells_;
};

}  // namespace capsflow
