// The checks of the run configuration (config_checks.hpp): what a key's own range cannot tell, refused with one line
// that names the key the user is most likely to change. Run once every section is read (read_config), and again by
// validate_run_config for a Config built in code.
#include "host/physics/config_checks.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>

#include "host/base/errors.hpp"
#include "host/physics/config_reader.hpp"
#include "kernels/ggem_kernels.hpp"

namespace capsflow::config_detail {

[[noreturn]] void run_error(const Config& c, const std::string& where, const std::string& what) {
  throw InputError(c.origin(where) + ": " + one_line(what));
}

namespace {

// Checks across keys, once every section is read. The message names the key the user is most likely to change.
void check_period_fits_cutoff(const Config& c, const char* key, double L, double cutoff) {
  // The local sum sees each source at most once per period (minimum image): r_c <= L / 2.
  if (L >= 2.0 * cutoff) return;
  // A cutoff that [ggem] tolerance chose is the tolerance's doing (it was blamed on Lx and the cutoff, neither of
  // which the user wrote); one from alpha's default is alpha's (alpha = 1e-300 used to be blamed on Lx).
  if (c.ggem.tolerance > 0.0 && cutoff == with_ggem_tolerance(c.ggem, c.ggem.tolerance).cutoff)
    throw InputError(c.origin("[ggem] tolerance") + ": tolerance = " + fmt(c.ggem.tolerance) + " (with alpha = " +
                     fmt(c.ggem.alpha) + ") gives the local cutoff " + fmt(cutoff) + ", which needs [domain] " + key +
                     " >= 2 * cutoff = " + fmt(2.0 * cutoff) + " (" + key + " = " + fmt(L) +
                     "); expected a looser tolerance, a larger [ggem] alpha, or a larger " + key);
  if (cutoff == default_cutoff(c.ggem.alpha))
    throw InputError(c.origin("[ggem] alpha") + ": alpha = " + fmt(c.ggem.alpha) + " gives the local cutoff 3.5 / alpha = " +
                     fmt(cutoff) + ", which needs [domain] " + key + " >= 2 * cutoff = " + fmt(2.0 * cutoff) + " (" +
                     key + " = " + fmt(L) + "); expected a larger alpha (or " + key + ")");
  throw InputError(c.origin(std::string("[domain] ") + key) + ": " + key + " = " + fmt(L) +
                   " is too small for the cutoff " + fmt(cutoff) + ": need " + key + " >= 2 * cutoff = " +
                   fmt(2.0 * cutoff));
}

// Capsules need room for the cutoff plus two radii in each period (so that no capsule meets its own periodic image
// through the local sum).
// "radius " when every species is a sphere (the words of the messages before shapes existed), else "bounding radius ".
std::string radius_words(const Config& c) {
  for (const SpeciesSpec& sp : c.species)
    if (sp.shape.kind != ShapeKind::Sphere) return "bounding radius ";
  return "radius ";
}

// `a` is the largest bounding radius of the species (the radius, for spheres).
void check_period_fits_capsules(const Config& c, const char* key, double L) {
  const double a = c.max_bounding_radius(), need = 2.0 * (c.ggem.cutoff + 2.0 * a);
  if (L >= need) return;
  run_error(c, std::string("[domain] ") + key,
            std::string(key) + " = " + fmt(L) + " is too small for capsules of " + radius_words(c) + fmt(a) +
                " with the cutoff " +
                fmt(c.ggem.cutoff) + ": need " + key + " >= 2 (cutoff + 2a) = " + fmt(need) +
                    " (so that no capsule meets its own periodic image)");
}

// [suspension] and [[capsule]] place capsules in two ways: one at a time.
void check_one_placement(const Config& c) {
  if (c.suspension && !c.capsule_list.empty())
    run_error(c, "[suspension]",
              "expected either [suspension] (random placement) or [[capsule]] (explicit capsules), got both");
}

// Species names unique; capsules need a species.
void check_species(const Config& c) {
  for (std::size_t i = 0; i < c.species.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (c.species[i].name == c.species[j].name)
        run_error(c, "[[species]] " + std::to_string(i + 1) + " name",
                  "expected a name that no other [[species]] uses, got string \"" + c.species[i].name +
                      "\" (also [[species]] " + std::to_string(j + 1) + ")");

  if (c.defines_capsules() && c.species.empty())
    run_error(c, "[[species]]", "expected at least one [[species]] (name, ca) for the capsules, got none");
}

// The stop rules ask for a shape of the problem: every capsule pinned (steady_stop), a pair (stop_pair_dx).
void check_stop_rules(const Config& c) {
  if (c.time.steady_stop && c.defines_capsules()) {
    bool all_pinned = !c.suspension;
    for (const CapsuleSpec& k : c.capsule_list) all_pinned = all_pinned && k.pinned;
    if (!all_pinned)
      run_error(c, "[time] steady_stop",
                "expected every capsule pinned ([[capsule]] pinned = true) for a stop at steady state, got free "
                "capsules");
  }

  if (c.time.stop_pair_dx && (c.suspension || c.capsule_list.size() != 2))
    run_error(c, "[time] stop_pair_dx",
              "expected exactly two [[capsule]] entries (a pair) for a stop on their separation, got " +
                  (c.suspension ? std::string("[suspension]")
                                : std::to_string(c.capsule_list.size()) + " [[capsule]]"));
}

void check_reference_ca(const Config& c) {
  if (c.time.reference_ca && !c.species.empty()) {
    double ca_min = c.species[0].ca;
    for (const SpeciesSpec& sp : c.species) ca_min = std::min(ca_min, sp.ca);
    // A larger reference Ca would step the stiffest capsules beyond the rule's stability margin (D8).
    if (*c.time.reference_ca > ca_min)
      run_error(c, "[time] reference_ca",
                "expected a number <= the smallest [[species]] ca (" + fmt(ca_min) + "), got " +
                    fmt(*c.time.reference_ca));
  }
}

// [suspension] fractions: one per species, summing to 1.
void check_fractions(const Config& c) {
  if (c.suspension) {
    const auto& f = c.suspension->fractions;
    if (f.size() != c.species.size())
      run_error(c, "[suspension] fractions",
                "expected one fraction per [[species]] (" + std::to_string(c.species.size()) + "), got " +
                    std::to_string(f.size()));
    double sum = 0.0;
    for (double v : f) sum += v;
    if (!(std::abs(sum - 1.0) <= 1e-9 * static_cast<double>(f.size())))
      run_error(c, "[suspension] fractions", "expected number fractions that sum to 1, got sum " + fmt(sum));
  }
}

void check_capsule_species(const Config& c) {
  for (std::size_t i = 0; i < c.capsule_list.size(); ++i)
    if (c.species_index(c.capsule_list[i].species) < 0) {
      std::string known;
      for (const auto& s : c.species) known += (known.empty() ? "\"" : ", \"") + s.name + "\"";
      run_error(c, "[[capsule]] " + std::to_string(i + 1) + " species",
                "expected the name of a [[species]] (" + (known.empty() ? std::string("none defined") : known) +
                    "), got string \"" + c.capsule_list[i].species + "\"");
    }
}

// The box holds the capsules: between the walls (the largest bounding radius decides), in each period, and a
// [suspension] count below close packing.
void check_box_fits_capsules(const Config& c) {
  const double amax = c.max_bounding_radius(), gap = c.time.min_gap, H = c.domain.H;
  if (amax + gap > H - amax - gap)
    run_error(c, "[domain] H",
              "H = " + fmt(H) + " is too narrow for capsules of " + radius_words(c) + fmt(amax) + " with min_gap " +
                  fmt(gap) + ": need H >= 2 (a + min_gap) = " + fmt(2.0 * (amax + gap)));
  check_period_fits_capsules(c, "Lx", c.domain.Lx);
  check_period_fits_capsules(c, "Lz", c.domain.Lz);

  if (c.suspension && c.suspension->count) {
    const double vcap = mean_capsule_volume(c);
    const double phi = static_cast<double>(*c.suspension->count) * vcap / (H * c.domain.Lx * c.domain.Lz);
    if (!(phi < 0.5))
      run_error(c, "[suspension] count",
                "expected a count whose volume fraction N_p (4/3 pi a^3) / (H Lx Lz) is < 0.5, got count = " +
                    std::to_string(*c.suspension->count) + " (volume fraction " + fmt(phi) + ")");
  }
}

// Explicit capsules inside the walls with min_gap.
void check_capsules_between_walls(const Config& c) {
  const double gap = c.time.min_gap, H = c.domain.H;
  for (std::size_t i = 0; i < c.capsule_list.size(); ++i) {
    const auto& p = c.capsule_list[i].center;
    const double a = c.species_bounding_radius(static_cast<std::size_t>(c.species_index(c.capsule_list[i].species)));
    const double ylo = a + gap, yhi = H - a - gap;
    const std::string where = "[[capsule]] " + std::to_string(i + 1) + " center";
    const std::string name = "capsule " + std::to_string(i + 1);
    const double tol = 1e-12 * std::max(1.0, H);  // exactly at a + min_gap is allowed, whatever the rounding
    if (p[1] < ylo - tol || p[1] > yhi + tol) {
      const bool low = p[1] < ylo;
      const bool crosses = low ? p[1] - a < 0.0 : p[1] + a > H;
      const std::string how = crosses ? " crosses the wall " : " comes within min_gap of the wall ";
      run_error(c, where,
                name + " at y = " + fmt(p[1]) + how + (low ? "y = 0" : "y = H = " + fmt(H)) +
                    ": needs a + min_gap <= y <= H - a - min_gap (" + fmt(ylo) + " <= y <= " + fmt(yhi) + ")");
    }
  }
}

// Explicit capsules apart by min_gap (nearest periodic image).
void check_capsules_apart(const Config& c) {
  const double gap = c.time.min_gap;
  for (std::size_t i = 0; i < c.capsule_list.size(); ++i)
    for (std::size_t j = 0; j < i; ++j) {
      const auto& p = c.capsule_list[i].center;
      const auto& q = c.capsule_list[j].center;
      const double ri = c.species_bounding_radius(static_cast<std::size_t>(c.species_index(c.capsule_list[i].species)));
      const double rj = c.species_bounding_radius(static_cast<std::size_t>(c.species_index(c.capsule_list[j].species)));
      const double dmin = ri + rj + gap;  // 2a + min_gap for equal spheres, bit for bit
      const double dx = min_image(p[0] - q[0], c.domain.Lx), dy = p[1] - q[1],
                   dz = min_image(p[2] - q[2], c.domain.Lz);
      const double d = std::sqrt(dx * dx + dy * dy + dz * dz);
      if (d < dmin * (1.0 - 1e-12))  // exactly 2a + min_gap apart is allowed, whatever the rounding of d
        run_error(c, "[[capsule]] " + std::to_string(i + 1) + " center",
                  "capsule " + std::to_string(i + 1) + " overlaps capsule " + std::to_string(j + 1) +
                      ": centre distance " + fmt(d) + " (nearest periodic image) < " +
                      (ri == rj ? std::string("2a") : std::string("r_i + r_j (bounding radii)")) + " + min_gap = " +
                      fmt(dmin));
    }
}

}  // namespace

bool every_species_a_drop(const Config& c) {
  if (c.species.empty()) return c.capsules.membrane.law == MembraneLaw::SurfaceTension;
  for (std::size_t i = 0; i < c.species.size(); ++i)
    if (c.species_membrane(i).law != MembraneLaw::SurfaceTension) return false;
  return true;
}

void check_drop_inflation(const Config& c) {
  if (!c.capsules.inflation_given || !every_species_a_drop(c)) return;
  run_error(c, "[capsules] inflation",
            "expected no inflation when every capsule is a drop (law = \"surface-tension\": a drop has no reference "
            "state to inflate from), got inflation = " + fmt(c.capsules.membrane.inflation));
}

void cross_check(const Config& c) {
  check_period_fits_cutoff(c, "Lx", c.domain.Lx, c.ggem.cutoff);
  check_period_fits_cutoff(c, "Lz", c.domain.Lz, c.ggem.cutoff);
  // Sizes beyond int (alpha = 1e300, H = 1e300) would wrap to a tiny grid and change the physics silently.
  if (const std::string e = ggem_grid_size_error(c.domain, c.ggem); !e.empty()) {
    const std::size_t colon = e.find(": ");  // "[ggem] alpha: why": name the key's origin (file or --set)
    throw InputError(c.origin(e.substr(0, colon)) + e.substr(colon));
  }
}

// The solve works in the run's own units: velocities of order shear_rate * H, stresses and tensions (G = mu
// shear_rate a / Ca) of order viscosity * shear_rate (times a length). Far from 1 their products overflow or underflow a double (shear_rate = 1e300
// moved nodes by inf, and was blamed on cfl, Ca and inflation): the scales are held to [1e-100, 1e100], and a
// refusal names the factor furthest from 1. The results are in strain units and do not depend on these scales.
void check_unit_scales(const Config& c) {
  constexpr double kLo = 1e-100, kHi = 1e100;
  const double L = std::max({c.domain.H, c.domain.Lx, c.domain.Lz});
  const char* side = L == c.domain.H ? "[domain] H" : L == c.domain.Lx ? "[domain] Lx" : "[domain] Lz";
  struct Factor {
    const char* key;
    double value;
  };
  auto refuse = [&](const char* scale, double v, std::initializer_list<Factor> factors) {
    const Factor* worst = factors.begin();
    for (const Factor& f : factors)
      if (std::abs(std::log10(f.value)) > std::abs(std::log10(worst->value))) worst = &f;
    run_error(c, worst->key,
              std::string(worst->key) + " = " + fmt(worst->value) +
                  " gives " + scale + " of order " + fmt(v) + ", beyond what the solve's double arithmetic carries (" +
                  fmt(kLo) + " to " + fmt(kHi) + "); expected the run's quantities in units near 1 (the results are " +
                  "in strain units and the same for any unit of time, length and viscosity)");
  };
  const double velocity = c.flow.shear_rate * L;
  if (!(velocity >= kLo && velocity <= kHi))
    refuse("velocities (shear_rate * the box's largest side)", velocity,
           {{"[flow] shear_rate", c.flow.shear_rate}, {side, L}});
  // (The radius, a length, is the first step's to judge: it names the radius key that set it, [[species]] or not.)
  const double stress = c.domain.viscosity * c.flow.shear_rate;
  if (!(stress >= kLo && stress <= kHi))
    refuse("viscous stresses and membrane tensions (viscosity * shear_rate)", stress,
           {{"[flow] shear_rate", c.flow.shear_rate}, {"[domain] viscosity", c.domain.viscosity}});
}

void check_run_sections(const Config& c) {
  check_unit_scales(c);
  check_one_placement(c);
  check_species(c);
  check_stop_rules(c);
  check_reference_ca(c);
  check_fractions(c);
  check_capsule_species(c);
  if (!c.defines_capsules()) return;
  check_box_fits_capsules(c);
  check_capsules_between_walls(c);
  check_capsules_apart(c);
}

}  // namespace capsflow::config_detail

namespace capsflow {

using config_detail::check_run_sections;
using config_detail::cross_check;
using config_detail::one_line;
using config_detail::run_error;

void validate_run_config(const Config& c) {
  if (c.species.empty())
    run_error(c, "[[species]]", "expected at least one [[species]] (name, ca) for capsflow run, got none");
  if (!c.defines_capsules())
    run_error(c, "[suspension]",
              "expected either [suspension] (random placement) or [[capsule]] (explicit capsules) for capsflow run, "
              "got neither");
  if (!c.time.end)
    run_error(c, "[time] end", "expected a finite number > 0 (strain units), got nothing (required by capsflow run)");
  cross_check(c);
  check_run_sections(c);
}

void check_output_file_name(const std::string& file, const std::string& where) {
  const std::filesystem::path p(file);
  if (file.empty() || p.filename().empty() || p.filename() == "." || p.filename() == "..")
    throw InputError(where + ": expected a file name (OUT.h5), got \"" + one_line(file) + "\"");
  // OUT.xdmf names OUT.h5 as "OUT.h5:/frames/...": readers split at the first ':'.
  if (p.filename().string().find(':') != std::string::npos)
    throw InputError(where + ": expected a file name without ':' (the XDMF index refers to the file as "
                     "NAME:/path), got \"" + one_line(file) + "\"");
}

}  // namespace capsflow
