// The implementation of force_terms.hpp: the membrane's force terms, each with its own step limit.
#include "host/physics/force_terms.hpp"

#include <algorithm>
#include <limits>

namespace capsflow {

double ForceTerm::step_limit(const CapsuleGeometry&, const StepScales&) const {
  return std::numeric_limits<double>::infinity();
}

void ElasticForce::add(CapsuleState& s, Backend backend) { s.compute_in_plane_forces(backend); }

BendingForce::BendingForce(const CapsuleState& s) : kappa_(s.bending_rigidity()) {
  for (double k : kappa_) kappa_max_ = std::max(kappa_max_, k);
}

void BendingForce::add(CapsuleState& s, Backend backend) {
  // Without bending the kernel is not called at all, so such runs keep their bits.
  if (s.has_bending())
    s.add_bending_forces(backend, s.Fx.data(), s.Fy.data(), s.Fz.data(), s.node_area.data(), s.fx.data(),
                         s.fy.data(), s.fz.data());
}

double BendingForce::step_limit(const CapsuleGeometry& g, const StepScales& k) const {
  // Per capsule: its own shortest edge and rigidity, so small stiff-free capsules (platelets without bending) or
  // fine meshes of other species do not set the bending limit of the red cells.
  double dt = std::numeric_limits<double>::infinity();
  for (std::size_t c = 0; c < kappa_.size(); ++c) {
    if (!(kappa_[c] > 0.0)) continue;
    dt = std::min(dt, bending_limit(k, g.min_edge[c], kappa_[c]));
  }
  return dt;
}

std::vector<std::unique_ptr<ForceTerm>> make_force_terms(const CapsuleState& s) {
  std::vector<std::unique_ptr<ForceTerm>> t;
  t.push_back(std::make_unique<ElasticForce>());
  t.push_back(std::make_unique<BendingForce>(s));
  return t;
}

}  // namespace capsflow
