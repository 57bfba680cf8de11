#pragma once
// The configuration keys behind a derived value, for messages that refuse or stop a run: each key named where its
// value came from ([[species]] N key when that species sets it, else the [capsules] default it inherits), with the
// value. A message that says "check [capsules] inflation" when the 1e300 sat in [[species]] 2 sends the user to the
// wrong line.
//
// Usage:
//     throw InputError(cfg.source + ": the membrane forces ...; expected finite forces (" + membrane_keys(cfg) + ")");
#include <cstddef>
#include <string>

#include "host/physics/config.hpp"

namespace capsflow {

// Species i's membrane inputs: "[[species]] 1 ca = 0.2, [[species]] 1 inflation = 1e+300, [capsules] radius = 1"
// (law, skalak_c and bending_modulus when they apply). i counts from 0; the message counts from 1.
std::string species_membrane_keys(const Config& c, std::size_t i);
// Every species' (joined by "; ").
std::string membrane_keys(const Config& c);
// Where the step rule's Ca of species i comes from (Config::species_step_ca, or [time] reference_ca in its place):
// "[[species]] 2 ca = 0.1 / 3.2e+299, the stiffness factor of law = \"skalak\" with [[species]] 2 skalak_c = 1e+300",
// with the radius and viscosity-ratio factors when they are not 1.
std::string step_ca_keys(const Config& c, std::size_t i);
// The species (index from 0) with the smallest species_step_ca: the one that sets Ca_ref.
std::size_t step_ca_species(const Config& c);

}  // namespace capsflow
