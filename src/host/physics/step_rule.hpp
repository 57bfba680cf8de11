#pragma once
// The step rule (TimeStepRule; Config's enum StepRule says which rule): the one home of dt's formula
// (docs/method.md section 4.1, D8), for the run and for the dry run's estimate (run_estimate.cpp), which before this
// wrote it a second time and drifted from the run once. The keys it reads ([time] cfl, bending_cfl,
// near_contact_factor, c_gap, max_step_ratio, dt_floor) are read from the Config here and nowhere else outside the
// configuration reader.
//
//   membrane rule: dt_M = cfl Ca_ref h / a_ref, h the shortest edge of any capsule, combined harmonically with each
//                  force term's own limit (bending: bending_cfl mu gammadot min_k h_k^3 / kappa_k; the rates add);
//                  times near_contact_factor while a pair is closer than h_e; capped by the collision cap
//                  c_gap max(g, min_gap) / w over the gaps g < h_e closing at w > 0;
//   paper rule:    dt = cfl Ca_ref h / a_ref, h the smallest node-node distance (own capsule or another);
//   then:          capped at max_step_ratio dt_{n-1} (the AB2 weights extrapolate by r / 2).
//
// The rule reads the state through a StepView the caller fills (the geometry at x^n and two callbacks for the
// costly parts, which only one rule each needs), so it includes nothing of the Simulation (HOOMD's Integrator asks
// its ForceComputes, not the system, for their limits).
//
//   TimeStepRule rule(cfg, placements, state, force_terms);
//   StepInfo info;
//   rule.choose(info, StepView{geometry, min_distance, closing, have_history, dt_previous});
//   if (std::string why = rule.below_floor(info, time); !why.empty()) ...
#include <array>
#include <functional>
#include <string>
#include <vector>

#include "host/physics/config.hpp"
#include "host/physics/contact.hpp"
#include "host/physics/initial_conditions.hpp"
#include "host/state/capsule_state.hpp"
#include "host/state/step_workspace.hpp"
#include "kernels/device_cells.hpp"

namespace capsflow {

class ForceTerm;  // force_terms.hpp: each term reports its own step limit

enum class StopReason { None, NotFinite, LeftSlit, DtBelowFloor, MeshTooLarge, ContactFailed, SolveNotConverged };
const char* stop_reason_name(StopReason r);

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

// The rule's constants, read from the configuration once. Force terms get their Courant numbers from here, so a
// term's limit uses the configured number without reading the Config itself.
struct StepScales {
  double cfl = 0.0;          // [time] cfl
  double bending_cfl = 0.0;  // [time] bending_cfl
  double bending = 0.0;      // bending_cfl mu gammadot, in that order of products (the run's bits since issue 26)
  double a_ref = 1.0;        // [capsules] radius
};
StepScales step_scales(const Config& c);

// The membrane and paper rules' step for the edge h (D8): cfl Ca_ref h / a_ref in strain units. Ca_ref is a pure
// number, so h enters as a multiple of a_ref and the same problem in another length unit takes the same steps
// (until issue 37 the rule was cfl Ca_ref h: a [capsules] radius of 2 doubled the step). Exactly cfl Ca_ref h for
// a_ref = 1.
double membrane_step(const StepScales& k, double ca_ref, double h);
// A bending limit bending_cfl mu gammadot h^3 / kappa (strain units).
double bending_limit(const StepScales& k, double h, double kappa);

// h_e: the mean edge of the first capsule's mesh (every capsule starts with the same one), the range below which a
// gap counts as near contact; 0 without capsules.
double near_contact_range(const CapsuleState& s);

// The paper rule's h: the smallest node-node distance (own capsule: the shortest edge of g, the geometry at s's
// positions; other capsules: nodes within that range, minimum image). Sets `between` when it came from two capsules.
// cells: the device's node cell list on the device backend (null elsewhere: the host's).
double min_node_distance(const CapsuleState& s, const CapsuleGeometry& g, const SlitGeometry& domain, Backend backend,
                         StepWorkspace& ws, DeviceNodeCells* cells, bool* between);

// Ca_ref of the rule: the smallest Config::species_step_ca over the placed capsules, or [time] reference_ca times
// the same law and size factors. Throws InputError for a reference_ca above the smallest Ca.
double rule_ca_ref(const Config& c, const std::vector<CapsulePlacement>& placements);

// The membrane rule's gap caps on info.dt_membrane (both the run and the estimate's first step): sets pair_gap,
// dt_collision, dt and limit.
void apply_gap_caps(const Config& c, double h_near, const ClosingLimits& cl, StepInfo& info);

// What the rule reads of the state at x^n.
struct StepView {
  const CapsuleGeometry& geometry;                      // at x^n (shortest edges, centroids)
  std::function<double(bool* between)> min_distance;   // paper rule: the smallest node-node distance
  std::function<ClosingLimits()> closing;              // membrane rule: the gaps at geometry's centroids
  bool have_history = false;                           // a previous step exists (the ratio cap)
  double dt_previous = 0.0;
};

class TimeStepRule {
 public:
  TimeStepRule() = default;
  // s: the state as placed (h_e from its mesh, the rigidities); terms: the force terms whose step limits combine
  // with the membrane rule. cfg and the terms are kept by reference: the caller outlives the rule.
  TimeStepRule(const Config& cfg, const std::vector<CapsulePlacement>& placements, const CapsuleState& s,
               std::vector<const ForceTerm*> terms);

  // The next step's size into info (dt, limit and the rule's fields).
  void choose(StepInfo& info, const StepView& now) const;
  // "" when info.dt is at least [time] dt_floor; else the stop message (naming the key that held the step).
  std::string below_floor(const StepInfo& info, double time) const;
  // The formula behind info.dt with its keys and values ("[time] cfl = 0.5 x Ca_ref = ..."), for refusals.
  std::string explain(const StepInfo& info) const;
  // "" when info.dt is finite and at least dt_floor; else why not, with explain()'s text.
  std::string refuse(const StepInfo& info) const;

  double ca_ref() const { return ca_ref_; }
  double near_contact_range() const { return h_near_; }
  double dt_floor() const;
  // The bending limit at one shortest edge h for the stiffest capsule (inf without bending), and an elastic limit
  // combined with it, 1 / (1/dt + 1/bending_step(h)): the probe's and the tests' single-size form of the rule.
  double bending_step(double h) const;
  double with_bending(double dt_elastic, double h) const;

 private:
  const Config* cfg_ = nullptr;
  StepScales k_;
  double ca_ref_ = 0.0, h_near_ = 0.0, kappa_max_ = 0.0;
  std::size_t ca_species_ = 0;  // the species whose Ca sets Ca_ref (to name its keys)
  std::vector<const ForceTerm*> terms_;
  // dt combined harmonically with each term's own limit (terms without one leave dt's bits alone).
  double with_force_limits(double dt, const CapsuleGeometry& g) const;
};

// The dry run's estimate of the rule's steps per strain unit (docs/performance.md 5): the rule's formula at the
// calibrated shortest edges of a fresh and of a developed suspension, Ca_ref as the run takes it.
struct StepRateEstimate {
  double ca_ref = 0.0, start = 0.0, developed = 0.0;  // Ca_ref; steps per strain unit
};
StepRateEstimate estimate_step_rates(const Config& c);
// The estimate's first step of a listed-capsule run under the membrane rule: dt_rule (1 / start) held by the gap
// caps at the placed capsules with the imposed flow's velocities. h_near: near_contact_range of that state.
StepInfo estimate_first_step(const Config& c, double dt_rule, double h_near, const ClosingLimits& cl);

}  // namespace capsflow
