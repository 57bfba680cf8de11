#pragma once
// Force terms: the membrane's forces as a list of terms, each adding its part of the nodal force F and the density
// on the fluid f = F / A at the current positions, and each reporting its own step limit (HOOMD-blue's
// ForceCompute list). The Simulation calls them in order before the velocity model; the step rule combines the
// limits of the terms that have one with the membrane rule (step_rule.hpp). docs/adding_a_force_term.md walks
// through adding one.
//
//   ElasticForce: the in-plane law per capsule (neo-Hookean, Skalak, surface tension); the first term: it overwrites
//                 F, the node areas A and f. Its limit is the membrane rule itself (cfl Ca_ref h / a_ref).
//   BendingForce: Helfrich bending where kappa > 0; adds to F and sets f = F / A. Its limit:
//                 bending_cfl mu gammadot min_k h_k^3 / kappa_k over the capsules with bending.
//
//   std::vector<std::unique_ptr<ForceTerm>> terms = make_force_terms(state);
//   for (auto& t : terms) t->add(state, backend);                       // F, A, f
//   dt = 1 / (1 / dt + 1 / t->step_limit(geometry, scales));            // for t->has_step_limit()
//
// Host classes: the kernels they call are free functions (no virtual call reaches device code).
#include <memory>
#include <vector>

#include "host/physics/step_rule.hpp"
#include "host/state/capsule_state.hpp"

namespace capsflow {

class ForceTerm {
 public:
  virtual ~ForceTerm() = default;
  virtual const char* name() const = 0;
  // Adds this term's forces at s's positions: F (nodal), node_area and f = F / node_area, all sized to the nodes.
  // On the device backend the arrays are device-valid (the caller declares them to the workspace).
  virtual void add(CapsuleState& s, Backend backend) = 0;
  // Whether the term limits the explicit step beyond the membrane rule; if so, its limit in strain units at
  // geometry g (k: the rule's Courant numbers and scales).
  virtual bool has_step_limit() const { return false; }
  virtual double step_limit(const CapsuleGeometry& g, const StepScales& k) const;
};

class ElasticForce final : public ForceTerm {
 public:
  const char* name() const override { return "elastic"; }
  void add(CapsuleState& s, Backend backend) override;
};

class BendingForce final : public ForceTerm {
 public:
  explicit BendingForce(const CapsuleState& s);  // the capsules' rigidities (fixed for the run)
  const char* name() const override { return "bending"; }
  void add(CapsuleState& s, Backend backend) override;
  bool has_step_limit() const override { return kappa_max_ > 0.0; }
  double step_limit(const CapsuleGeometry& g, const StepScales& k) const override;

 private:
  std::vector<double> kappa_;  // per capsule
  double kappa_max_ = 0.0;
};

// The run's terms, in the order they add: elastic, then bending.
std::vector<std::unique_ptr<ForceTerm>> make_force_terms(const CapsuleState& s);

}  // namespace capsflow
