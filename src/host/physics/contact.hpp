#pragma once
// Overlap / contact control after each time step (docs/method_contact.md, decision D5; docs/method_contact.md).
//
// Capsule pairs closer than min_gap and capsules closer than min_gap to a wall (y = 0, y = H) are translated
// rigidly - no rotation, no deformation - until no violation remains. The pair gap is the signed distance of a node
// to the other capsule's triangulated surface (negative inside; kernels/contact.hpp), the wall gap the node-to-wall
// distance. A gap equal to min_gap is not a violation (gap < min_gap, less a 1e-9 relative round-off allowance).
//
// Each iteration: detect (bounding spheres, then signed node-surface gaps of the candidate pairs, minimum image in x
// and z), push every violating pair apart along the line of centres e, then translate every capsule that is closer
// than min_gap to a wall along y by its deficit (the wall has the last word). Two pair rules:
//   Proportional (default): P moves by +need/2 e and Q by -need/2 e, where need = max over the violating nodes of
//       (1.01 min_gap - gap) / (e . n), n the surface normal at the node's closest point (e . n floored at 0.25).
//       The gap gained at that node equals its violation plus a 1 % margin: no more than the violation needs.
//   Amit: Amit's rule (FLEX mesh-amit.c): F_Q = (1 - min_gap / max(gap, 0.005)) e, F_P = -F_Q, move by REX F with
//       REX = 0.001. Its step vanishes as gap -> min_gap, so the gap approaches min_gap geometrically (factor ~0.9
//       per iteration) and may not reach it within max_iterations.
// Offsets are accumulated per capsule and added to the nodes once at the end; a configuration without violations
// is not touched at all (bit-identical).
//
// Every correction is recorded as a ContactEvent, one per pair (or capsule and wall) per call, whatever the number
// of iterations; the caller adds the time.
//
// Usage:
//     ContactStats st = resolve_contacts(state, Lx, Lz, H, 0.02, Backend::Threads);
//     if (!st.converged) { ... report: st.final_min_gap < min_gap ... }
//     for (const ContactEvent& ev : st.events) { ... }
#include <limits>
#include <vector>

#include "host/state/capsule_state.hpp"
#include "kernels/backend.hpp"

namespace capsflow {

enum class ContactRule { Proportional, Amit };

// One corrected contact of one resolve_contacts call: a pair (p < q, wall = -1) or a capsule and a wall (q = -1).
struct ContactEvent {
  int p = -1, q = -1;       // capsule indices; q = -1 for a wall event
  int wall = -1;            // -1: pair event; 0: wall y = 0; 1: wall y = H
  double gap_before = 0.0;  // gap when first detected (signed node-surface or node-wall distance)
  double dy_p = 0.0;        // total y translation of p by this contact's pushes, summed over iterations
  double dy_q = 0.0;        // same for q (0 for a wall event)
};

struct ContactStats {
  int iterations = 0;              // push rounds performed (0: nothing to do)
  long pair_corrections = 0;       // pair pushes, summed over iterations
  long wall_corrections = 0;       // capsule-wall pushes, summed over iterations
  long pair_events = 0;            // distinct pairs pushed (pair entries of events)
  long wall_events = 0;            // distinct (capsule, wall) pushes (wall entries of events)
  double initial_min_gap = std::numeric_limits<double>::infinity();  // over candidate pairs and walls, before
  double final_min_gap = std::numeric_limits<double>::infinity();    // after (inf: no pair candidate, no walls)
  double max_displacement = 0.0;   // largest capsule translation
  bool converged = true;           // false: violations remained after max_iterations
  // In order of first detection (iteration, then pairs by (p, q), then capsules, bottom wall before top).
  std::vector<ContactEvent> events;
};

// Resolves contacts in place; min_gap > 0, Lx, Lz > 2 max capsule radius, H > 0. Checks the backend with
// require_backend(). Does not throw when it fails to converge: returns converged = false (and final_min_gap).
[[nodiscard]] ContactStats resolve_contacts(CapsuleState& s, double Lx, double Lz, double H, double min_gap,
                                            Backend backend, int max_iterations = 1000,
                                            ContactRule rule = ContactRule::Proportional);

// The membrane step rule's view of the gaps (docs/method.md section 4.1), from the node velocities of the current
// state: capsule pairs and capsule-wall gaps closer than `range` (the element size h_e), and the shortest time in
// which one of them could close at its present rate. Pair gaps are signed node-surface distances as in the contact
// control (nearest features, minimum image); the closing rate of a node is its velocity relative to the other
// surface's at the closest point (linear on that triangle), along the outward direction.
struct ClosingLimits {
  double pair_gap = std::numeric_limits<double>::infinity();  // smallest pair gap (inf: none below range)
  double wall_gap = std::numeric_limits<double>::infinity();  // smallest node-wall gap (inf: none below range)
  double time_to_close = std::numeric_limits<double>::infinity();  // min max(g, floor) / w over closing gaps < range
};

// centroid: 3 per capsule (the current geometry's). range > 0, floor > 0 (the rule's min_gap).
ClosingLimits closing_limits(const CapsuleState& s, const std::vector<double>& centroid, const double* ux,
                             const double* uy, const double* uz, double Lx, double Lz, double H, double range,
                             double floor, Backend backend);

}  // namespace capsflow
