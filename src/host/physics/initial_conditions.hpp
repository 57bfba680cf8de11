#pragma once
// The initial condition of `capsflow run`: where the capsules start and which species each one is.
//
//   Config c = load_config("run.toml");
//   validate_run_config(c);
//   std::vector<CapsulePlacement> p = place_capsules(c);
//   for (const auto& q : p) state.add_capsule(q.center, c.species_radius(q.species), q.species, q.orientation);
//
// Explicit [[capsule]] entries are returned as given (in file order). With [suspension] the capsules are placed by
// random sequential addition from [suspension] seed (std::mt19937_64, uniform variates from its raw 64-bit output,
// so the result is the same with every standard library): each candidate centre is drawn uniformly in
// [0, Lx) x [e + min_gap, H - e - min_gap] x [0, Lz) and kept when it overlaps no placed capsule (nearest periodic
// image in x and z). e is the capsule's half-extent in y: its radius for a sphere. Two spheres overlap when their
// centres are closer than r + r' + min_gap (2a + min_gap for one size). A capsule of a non-spherical species draws a
// uniformly random orientation first, from a second generator (seeded with seed ^ 0x6a09e667f3bcc909, so spheres'
// positions do not depend on whether shapes are present); e is then its turned extent, and a pair within their
// bounding spheres (shape_bounding_radius) overlaps when a node of either's level-3 mesh lies inside the other shape
// scaled by (a + min_gap) / a: red cells pack closer than their bounding spheres would allow (haematocrit 0.2 and
// more). The number per species follows the fractions by largest-remainder rounding; the species are assigned to
// the capsules in a shuffled order drawn from the first generator. A capsule that cannot be placed in kMaxTriesPerCapsule consecutive draws stops the placement with
// an InputError that says which fraction was reached.
#include <array>
#include <vector>

#include "host/physics/config.hpp"

namespace capsflow {

struct CapsulePlacement {
  std::array<double, 3> center{};  // x in [0, Lx), z in [0, Lz) for placed capsules; explicit ones as given
  int species = 0;                 // index into Config::species
  bool pinned = false;             // [[capsule]] pinned (always false for [suspension])
  Rotation orientation = kIdentityRotation;  // body -> lab: [[capsule]] orientation; random for non-spherical
                                             // species of [suspension]; the identity for spheres
};

// Consecutive failed draws for one capsule before random sequential placement gives up.
inline constexpr long kMaxTriesPerCapsule = 100000;

// Number of capsules of [suspension]: count, or round(phi H Lx Lz / (4/3 pi a^3)) (at least 1 is required).
long suspension_count(const Config& c);

// Capsules per species from `total` and the number fractions, by largest-remainder rounding (ties: lower index).
std::vector<long> species_counts(long total, const std::vector<double>& fractions);

// The initial capsules. Requires a Config that passed validate_run_config (runs it again). Throws InputError.
std::vector<CapsulePlacement> place_capsules(const Config& c);

}  // namespace capsflow
