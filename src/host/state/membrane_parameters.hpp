#pragma once
// The membrane's constitutive parameters as a value (docs/method.md §2.3; decision D7): read by the configuration and
// used by CapsuleState, without the configuration depending on the capsule state.
#include <algorithm>

#include "kernels/membrane_forces.hpp"

namespace capsflow {

struct MembraneParameters {
  MembraneLaw law = MembraneLaw::NeoHookean;  // constitutive law (docs/method.md §2.3)
  double skalak_C = 1.0;                      // Skalak area-dilatation parameter C (> 0; unused for neo-Hookean)
  double inflation = 0.1;                     // beta: reference radius = a / (1 + beta) (D7), >= 0
};

// Incremental longitudinal modulus of the membrane, in units of Gs, about an equibiaxial stretch l (the prestress of
// inflation beta: l = 1 + beta): M = (l1 / l2) d^2W/dl1^2 at l1 = l2 = l, the stiffness of the fastest in-plane
// (grid-scale, dilatational) modes. At l = 1: 4 for neo-Hookean, 2 + 2C for Skalak (K + Gs, K = Gs (1 + 2C)).
//   neo-Hookean  M = 1 + 3 / l^6
//   Skalak       M = 3 l^2 - 1 + C (3 l^6 - l^2)
//   surface tension: no in-plane stiffness; its out-of-plane modes relax through the tension sigma = Gs, as a
//                neo-Hookean membrane's through its prestress: 1 here, so the rule keeps the neo-Hookean step.
inline double longitudinal_modulus(MembraneLaw law, double skalak_C, double l) {
  const double l2 = l * l, l6 = l2 * l2 * l2;
  if (law == MembraneLaw::Skalak) return 3.0 * l2 - 1.0 + skalak_C * (3.0 * l6 - l2);
  if (law == MembraneLaw::SurfaceTension) return 1.0;
  return 1.0 + 3.0 / l6;
}

// How much faster than a neo-Hookean membrane at the same inflation this one's fastest modes relax: the explicit
// step's limit shrinks by this factor (>= 1; exactly 1 for neo-Hookean, so such runs keep their step). The stability
// probe measures c / M = 0.32-0.36 for neo-Hookean and Skalak C = 1, 10, 50 at beta = 0 and 0.1 on spheres and red
// cells (docs/method.md section 4.1), so M carries the law's whole effect on the limit.
inline double step_stiffness_factor(const MembraneParameters& p) {
  const double l = 1.0 + p.inflation;
  return std::max(1.0,
                  longitudinal_modulus(p.law, p.skalak_C, l) / longitudinal_modulus(MembraneLaw::NeoHookean, 1.0, l));
}

// The step rule's factor on Ca for an inner/outer viscosity ratio lambda: (1 + lambda)/2, the interface equation's
// coefficient of u, by which a grid-scale mode relaxes slower (its double layer, that of a locally flat patch, nearly
// vanishes). Exactly 1 at lambda = 1. Capped at 3 (lambda 5), the largest ratio the stability probe measured
// (tests/validation_stability.cpp: the rate is 1.50 times lambda 1's at lambda 0.2 and 0.378 times at 5).
inline double step_viscosity_factor(double lambda) { return std::min(3.0, 0.5 * (1.0 + lambda)); }

}  // namespace capsflow
