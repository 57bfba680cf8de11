// The implementation of key_blame.hpp: the configuration keys behind a derived value, named in messages.
#include "host/physics/key_blame.hpp"

#include <cstdio>

#include "host/base/printable.hpp"
#include "host/state/membrane_parameters.hpp"

namespace capsflow {

namespace {

std::string num(double v) { return format_significant(v, 6); }

const char* law_name(MembraneLaw l) {
  return l == MembraneLaw::Skalak ? "skalak" : l == MembraneLaw::SurfaceTension ? "surface-tension" : "neo-hookean";
}

std::string species_label(std::size_t i) { return "[[species]] " + std::to_string(i + 1); }

}  // namespace

std::string species_membrane_keys(const Config& c, std::size_t i) {
  const SpeciesSpec& s = c.species[i];
  const std::string sp = species_label(i);
  const MembraneParameters m = c.species_membrane(i);
  std::string out = sp + " ca = " + num(s.ca);
  out += ", " + (s.inflation ? sp : std::string("[capsules]")) + " inflation = " + num(m.inflation);
  out += ", " + (s.radius ? sp : std::string("[capsules]")) + " radius = " + num(c.species_radius(i));
  if (m.law == MembraneLaw::Skalak)
    out += ", " + (s.skalak_c ? sp : std::string("[capsules]")) + " skalak_c = " + num(m.skalak_C);
  if (s.bending_modulus > 0.0) out += ", " + sp + " bending_modulus = " + num(s.bending_modulus);
  return out;
}

std::string membrane_keys(const Config& c) {
  std::string out;
  for (std::size_t i = 0; i < c.species.size(); ++i) out += (i ? "; " : "") + species_membrane_keys(c, i);
  return out;
}

std::string step_ca_keys(const Config& c, std::size_t i) {
  const SpeciesSpec& s = c.species[i];
  const std::string sp = species_label(i);
  const MembraneParameters m = c.species_membrane(i);
  std::string out = c.time.reference_ca ? "[time] reference_ca = " + num(*c.time.reference_ca) + " in place of " +
                                              sp + " ca = " + num(s.ca)
                                        : sp + " ca = " + num(s.ca);
  const double f = step_stiffness_factor(m);
  if (f != 1.0) {
    out += " / " + num(f) + ", the stiffness factor of law = \"" + law_name(m.law) + "\"";
    if (m.law == MembraneLaw::Skalak)
      out += " with " + (s.skalak_c ? sp : std::string("[capsules]")) + " skalak_c = " + num(m.skalak_C);
    out += " and " + (s.inflation ? sp : std::string("[capsules]")) + " inflation = " + num(m.inflation);
  }
  if (s.radius && *s.radius != c.capsules.radius)
    out += " x [capsules] radius / " + sp + " radius = " + num(c.capsules.radius / *s.radius);
  const double g = step_viscosity_factor(s.viscosity_ratio);
  if (g != 1.0) out += " x " + num(g) + " from " + sp + " viscosity_ratio = " + num(s.viscosity_ratio);
  return out;
}

std::size_t step_ca_species(const Config& c) {
  std::size_t best = 0;
  for (std::size_t i = 1; i < c.species.size(); ++i)
    if (c.species_step_ca(i) < c.species_step_ca(best)) best = i;
  return best;
}

}  // namespace capsflow
