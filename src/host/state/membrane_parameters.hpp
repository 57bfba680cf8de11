#pragma once
// The membrane's constitutive parameters as a value (method-spec 3.1; decision D7): read by the configuration and
// used by CapsuleState, without the configuration depending on the capsule state.
#include "kernels/membrane_forces.hpp"

namespace capsflow {

struct MembraneParameters {
  MembraneLaw law = MembraneLaw::NeoHookean;  // constitutive law (method-spec 3.1)
  double skalak_C = 1.0;                      // Skalak area-dilatation parameter C (> 0; unused for neo-Hookean)
  double inflation = 0.1;                     // beta: reference radius = a / (1 + beta) (D7), >= 0
};

}  // namespace capsflow
