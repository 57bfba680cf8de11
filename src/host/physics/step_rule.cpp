// The implementation of step_rule.hpp: the step rule, the one home of dt's formula.
#include "host/physics/step_rule.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "host/base/errors.hpp"
#include "host/base/printable.hpp"
#include "host/physics/force_terms.hpp"
#include "host/physics/key_blame.hpp"
#include "host/physics/step_watch.hpp"
#include "kernels/slit_cells.hpp"

namespace capsflow {

const char* stop_reason_name(StopReason r) {
  switch (r) {
    case StopReason::None: return "none";
    case StopReason::NotFinite: return "not-finite";
    case StopReason::LeftSlit: return "left-slit";
    case StopReason::DtBelowFloor: return "dt-below-floor";
    case StopReason::MeshTooLarge: return "mesh-too-large";
    case StopReason::ContactFailed: return "contact-failed";
    case StopReason::SolveNotConverged: return "gmres-not-converged";
  }
  return "?";
}

const char* step_limit_name(StepLimit l) {
  switch (l) {
    case StepLimit::Membrane: return "membrane";
    case StepLimit::NearContact: return "near-contact";
    case StepLimit::Collision: return "collision";
    case StepLimit::Ratio: return "ratio";
    case StepLimit::PaperGap: return "paper-gap";
  }
  return "?";
}

namespace {

// A double in a message: %g, never %f (a 1e300 would print as 300 digits).
std::string num(double v) { return format_significant(v, 6); }

}  // namespace

StepScales step_scales(const Config& c) {
  StepScales k;
  k.cfl = c.time.cfl;
  k.bending_cfl = c.time.bending_cfl;
  k.bending = c.time.bending_cfl * c.domain.viscosity * c.flow.shear_rate;
  k.a_ref = c.capsules.radius;
  return k;
}

double membrane_step(const StepScales& k, double ca_ref, double h) { return k.cfl * ca_ref * (h / k.a_ref); }

double bending_limit(const StepScales& k, double h, double kappa) { return k.bending * h * h * h / kappa; }

double near_contact_range(const CapsuleState& s) {
  if (s.num_capsules() == 0) return 0.0;
  const std::vector<int>& e = s.mesh().edges;
  double sum = 0.0;
  for (std::size_t k = 0; k < e.size() / 2; ++k) {
    const std::size_t a = static_cast<std::size_t>(e[2 * k]), b = static_cast<std::size_t>(e[2 * k + 1]);
    sum += std::hypot(s.x[a] - s.x[b], s.y[a] - s.y[b], s.z[a] - s.z[b]);
  }
  return e.empty() ? 0.0 : sum / static_cast<double>(e.size() / 2);
}

double min_node_distance(const CapsuleState& s, const CapsuleGeometry& g, const SlitGeometry& domain, Backend backend,
                         StepWorkspace& ws, DeviceNodeCells* cells, bool* between) {
  double h = g.global_min_edge;
  // Node pairs of different capsules closer than h, from one node cell list (cells >= h): O(nodes), where a search
  // per candidate capsule pair cost O(pairs nv^2). On the device backend the list is binned and searched on the
  // device over the resident positions (kernels/device_cells: one scalar comes back), elsewhere on the host
  // (kernels/slit_cells); the minimum is exact in any order, so every backend gets the same h.
  double hp;
  if (cells) {
    for (const auto* v : {&s.x, &s.y, &s.z}) ws.device_read(*v);
    cells->build(domain.Lx, domain.H, domain.Lz, h, s.x.size(), s.x.data(), s.y.data(), s.z.data());
    ws.note_scalar_results(1);
    hp = cells->min_node_distance_between_capsules(s.nodes_per_capsule(), s.x.data(), s.y.data(), s.z.data(), h);
  } else {
    SlitCells list;
    bin_points(list, domain.Lx, domain.H, domain.Lz, h, s.x.size(), s.x.data(), s.y.data(), s.z.data());
    hp = min_node_distance_between_capsules(backend, list, s.nodes_per_capsule(), s.x.data(), s.y.data(), s.z.data(),
                                            h);
  }
  const bool from_pair = hp < h;
  if (from_pair) h = hp;
  if (between) *between = from_pair;
  return h;
}

double rule_ca_ref(const Config& c, const std::vector<CapsulePlacement>& placements) {
  // Config::species_step_ca: Ca (a_ref / a) g / f with f the law's stiffness factor and g the viscosity ratio's
  // (membrane_parameters.hpp), a_ref the [capsules] radius: the relaxation rate of a grid-scale mode is
  // ~ f Gs / (g mu h), Gs = mu gammadot a / Ca. All three ratios are exactly 1 for neo-Hookean capsules of one size
  // at lambda 1, so such runs keep their steps bit for bit.
  double ca_min = std::numeric_limits<double>::infinity(), ca_rule = std::numeric_limits<double>::infinity();
  for (const CapsulePlacement& p : placements) {
    const auto sp = static_cast<std::size_t>(p.species);
    ca_min = std::min(ca_min, c.species[sp].ca);
    ca_rule = std::min(ca_rule, c.species_step_ca(sp));
  }
  if (!c.time.reference_ca) return ca_rule;
  if (*c.time.reference_ca > ca_min)
    throw InputError(c.source + ": [time] reference_ca: expected a number <= the smallest Ca of the capsules (" +
                     num(ca_min) + "), got " + num(*c.time.reference_ca));
  return *c.time.reference_ca * (ca_rule / ca_min);  // the same law and size factors
}

void apply_gap_caps(const Config& c, double h_near, const ClosingLimits& cl, StepInfo& info) {
  info.pair_gap = cl.pair_gap;
  // Velocities are per unit time; time_to_close in physical time, dt in strain units.
  info.dt_collision = c.time.c_gap * cl.time_to_close * c.flow.shear_rate;
  info.dt = info.dt_membrane;
  info.limit = StepLimit::Membrane;
  if (cl.pair_gap < h_near && c.time.near_contact_factor < 1.0) {
    info.dt *= c.time.near_contact_factor;
    info.limit = StepLimit::NearContact;
  }
  if (info.dt_collision < info.dt) {
    info.dt = info.dt_collision;
    info.limit = StepLimit::Collision;
  }
}

TimeStepRule::TimeStepRule(const Config& cfg, const std::vector<CapsulePlacement>& placements, const CapsuleState& s,
                           std::vector<const ForceTerm*> terms)
    : cfg_(&cfg), k_(step_scales(cfg)), h_near_(capsflow::near_contact_range(s)), terms_(std::move(terms)) {
  ca_ref_ = rule_ca_ref(cfg, placements);
  // The species whose Ca sets Ca_ref (the smallest Config::species_step_ca over the capsules), to name its keys.
  ca_species_ = static_cast<std::size_t>(placements.empty() ? 0 : placements[0].species);
  for (const CapsulePlacement& p : placements)
    if (cfg.species_step_ca(static_cast<std::size_t>(p.species)) < cfg.species_step_ca(ca_species_))
      ca_species_ = static_cast<std::size_t>(p.species);
  for (double k : s.bending_rigidity()) kappa_max_ = std::max(kappa_max_, k);
}

double TimeStepRule::dt_floor() const { return cfg_->time.dt_floor; }

double TimeStepRule::with_force_limits(double dt, const CapsuleGeometry& g) const {
  // Bending relaxes a mode of wavenumber k at a rate ~ kappa k^3 / mu, the in-plane elasticity at ~ Gs k / mu, and
  // the grid-scale modes feel both: the rates add, so the limits combine harmonically (the probe: docs/method.md
  // section 4.1). Only terms that have a limit take part, so runs without bending keep their bits.
  for (const ForceTerm* t : terms_)
    if (t->has_step_limit()) dt = 1.0 / (1.0 / dt + 1.0 / t->step_limit(g, k_));
  return dt;
}

double TimeStepRule::bending_step(double h) const {
  if (!(kappa_max_ > 0.0)) return std::numeric_limits<double>::infinity();
  return bending_limit(k_, h, kappa_max_);
}

double TimeStepRule::with_bending(double dt_elastic, double h) const {
  return 1.0 / (1.0 / dt_elastic + 1.0 / bending_step(h));
}

void TimeStepRule::choose(StepInfo& info, const StepView& now) const {
  const Config& c = *cfg_;
  if (c.time.step_rule == StepRule::Paper) {
    info.h = now.min_distance(&info.h_between_capsules);
    info.dt = membrane_step(k_, ca_ref_, info.h);  // D8, strain units
    info.limit = info.h_between_capsules ? StepLimit::PaperGap : StepLimit::Membrane;
    info.dt = with_force_limits(info.dt, now.geometry);
  } else {
    // The explicit step's stability limit scales with Ca times the element size; a gap is a transport question,
    // answered by the collision cap (docs/method.md section 4.1, with the stability probe's table).
    info.h = now.geometry.global_min_edge;
    info.dt_membrane = with_force_limits(membrane_step(k_, ca_ref_, info.h), now.geometry);
    apply_gap_caps(c, h_near_, now.closing(), info);
  }
  if (now.have_history) {
    // The AB2 weights extrapolate by r/2: a pair separating can raise h tenfold in one step (D8's cap).
    const double cap = c.time.max_step_ratio * now.dt_previous;
    if (info.dt > cap) {
      info.dt = cap;
      info.capped = true;
      info.limit = StepLimit::Ratio;
    }
    info.ratio = info.dt / now.dt_previous;
  }
}

std::string TimeStepRule::below_floor(const StepInfo& info, double time) const {
  const Config& c = *cfg_;
  if (info.dt >= c.time.dt_floor) return "";
  const std::string keys = step_limit_keys(c, info, h_near_);
  return "the time step " + num(info.dt) + " fell below [time] dt_floor = " + num(c.time.dt_floor) + " (set by " +
         (keys.empty() ? std::string(step_limit_name(info.limit)) + ", h = " + num(info.h) +
                             (info.h_between_capsules ? " between two capsules" : " inside a capsule")
                       : keys) +
         ") at strain " + num(time);
}

std::string TimeStepRule::explain(const StepInfo& info) const {
  const Config& c = *cfg_;
  std::string set_by = "[time] cfl = " + num(k_.cfl) + " x Ca_ref = " + num(ca_ref_) + " (" +
                       step_ca_keys(c, ca_species_) + ") x h / a_ref = " + num(info.h / k_.a_ref) +
                       " (the shortest edge h = " + num(info.h) + " from the radii and [capsules] mesh_level, a_ref the "
                       "[capsules] radius)";
  if (kappa_max_ > 0.0)
    set_by += ", combined with the bending limit [time] bending_cfl = " + num(k_.bending_cfl) +
              " x mu min_k(h_k^3 / kappa_k) over the capsules with bending, kappa up to " + num(kappa_max_) +
              " (from [[species]] bending_modulus)";
  // A step held below the membrane rule is named by the key that held it, not by the rule's (issue 37: a tiny c_gap
  // or near_contact_factor was reported as "[time] cfl = 0.5 x ...").
  const std::string held = step_limit_keys(c, info, h_near_);
  if (!held.empty()) set_by = held + ", below the membrane rule's " + num(info.dt_membrane) + " = " + set_by;
  return set_by;
}

std::string TimeStepRule::refuse(const StepInfo& info) const {
  const double floor = cfg_->time.dt_floor;
  if (std::isfinite(info.dt) && info.dt >= floor) return "";
  return "the time step " + num(info.dt) + " = " + explain(info) + " is " +
         (std::isfinite(info.dt) ? "below [time] dt_floor = " + num(floor) : std::string("not finite")) +
         "; expected a step of at least dt_floor";
}

// ---- The dry run's estimate -------------------------------------------------------------------------------------

namespace {

// Calibration of the steps per strain unit: h of dt = cfl Ca_ref h / a (membrane_step), measured on the set C runs
// of docs/reproduction.md (level 2, cfl 0.5, Ca_ref 0.2): 68 steps per strain unit over the first strain unit (a fresh
// random placement: h = 0.147 a) and 190-220 after strain 10 (X_f = 0: h = 0.05 a, set by the closest node pairs of
// neighbouring capsules near min_gap). A pure floppy suspension steps ~2x faster than the stiff one.
constexpr double kFreshH = 0.147;      // level 2; scales with the mesh spacing 2^-level
constexpr double kDevelopedH = 0.050;  // gap-limited: the same at every level (capped by the fresh h)
// The membrane rule ([time] step_rule = "membrane"): h is the shortest edge of the deformed capsules, 0.227 a at
// level 2 in set A and C alike (44 steps per strain unit at cfl 0.5, Ca_ref 0.2: set A over [0, 20] with the gap
// term removed, set C over [0, 3], docs/performance.md section 7), fresh or developed. A developed suspension
// always has pairs within h_e, so its steps carry the near-contact factor.
constexpr double kMembraneH = 0.227;   // level 2; scales with the mesh spacing 2^-level

}  // namespace

StepRateEstimate estimate_step_rates(const Config& c) {
  StepRateEstimate r;
  const StepScales k = step_scales(c);
  // Ca_ref as the run takes it (rule_ca_ref): Ca (a_ref / a) / f over the species, with the law's stiffness factor f
  // and the viscosity ratio's factor; the shortest edge scales with the smallest species' radius (shapes' distortion
  // not counted).
  // The smallest radius of the species (the [capsules] radius only when no species gives one: it is a default).
  double ca_min = c.species.empty() ? 1.0 : c.species[0].ca;
  double a_min = c.species.empty() ? c.capsules.radius : std::numeric_limits<double>::infinity();
  double ca_rule = c.species.empty() ? 1.0 : std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < c.species.size(); ++i) {
    const double a = c.species_radius(i);
    ca_min = std::min(ca_min, c.species[i].ca);
    ca_rule = std::min(ca_rule, c.species_step_ca(i));
    a_min = std::min(a_min, a);
  }
  r.ca_ref = c.time.reference_ca ? *c.time.reference_ca * (ca_rule / ca_min) : ca_rule;
  const double level_scale = std::pow(2.0, 2 - c.capsules.mesh_level);
  const bool dilute = !c.suspension;
  if (c.time.step_rule == StepRule::Membrane) {
    const double h = kMembraneH * level_scale * a_min;  // the smallest species' shortest edge
    r.start = 1.0 / membrane_step(k, r.ca_ref, h);
    r.developed = dilute ? r.start : 1.0 / (c.time.near_contact_factor * membrane_step(k, r.ca_ref, h));
    // Bending adds its rate (1/dt_B, dt_B = bending_cfl mu gammadot h^3 / kappa, kappa = kb Gs a^2, Gs = mu gammadot
    // a / Ca; mu gammadot cancels), each species with its own edge.
    double bending_rate = 0.0;
    for (std::size_t i = 0; i < c.species.size(); ++i) {
      const SpeciesSpec& sp = c.species[i];
      if (!(sp.bending_modulus > 0.0)) continue;
      const double a = c.species_radius(i), hb = kMembraneH * level_scale * a;  // this species' shortest edge
      const double kappa = sp.bending_modulus * (a / sp.ca) * a * a;
      bending_rate = std::max(bending_rate, kappa / (k.bending_cfl * hb * hb * hb));
    }
    r.start += bending_rate;
    r.developed += bending_rate;
  } else {
    const double a = c.capsules.radius;  // the calibration's h are in units of a
    const double h_fresh = kFreshH * level_scale * a;
    const double h_dev = std::min(h_fresh, kDevelopedH * a);
    r.start = 1.0 / membrane_step(k, r.ca_ref, h_fresh);
    r.developed = dilute ? r.start : 1.0 / membrane_step(k, r.ca_ref, h_dev);
  }
  return r;
}

StepInfo estimate_first_step(const Config& c, double dt_rule, double h_near, const ClosingLimits& cl) {
  StepInfo info;  // the first step as TimeStepRule::choose sets it
  info.dt_membrane = dt_rule;
  apply_gap_caps(c, h_near, cl, info);
  return info;
}

}  // namespace capsflow
