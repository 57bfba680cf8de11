// The implementation of contact.hpp: the overlap / contact control after each step (capsule pairs and walls).
#include "host/physics/contact.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "host/base/backend_select.hpp"
#include "host/base/errors.hpp"
#include "kernels/contact.hpp"
#include "kernels/ggem_kernels.hpp"
#include "kernels/step_update.hpp"

namespace capsflow {
namespace {

constexpr double kRex = 0.001;         // Amit's relaxation factor REX
constexpr double kAmitGapFloor = 0.005;  // Amit's max(gap, 0.005)
constexpr double kMargin = 0.01;       // proportional pushes and wall pushes aim at (1 + kMargin) min_gap
// A gap within this relative distance of min_gap is not a violation: a node placed exactly at min_gap computes to
// min_gap +- a few 1e-15 (coordinates of order the box), and must not trigger a push.
constexpr double kRoundoff = 1e-9;
// Floor of e . n in the proportional push: a grazing (e . n -> 0) or reversed (deep overlap, e . n < 0) contact would
// otherwise ask for an unbounded push along e; with the floor a step is at most 4 times the violation and the
// iterations finish the job.
constexpr double kMinAlignment = 0.25;

}  // namespace

ContactStats resolve_contacts(CapsuleState& s, double Lx, double Lz, double H, double min_gap, Backend backend,
                              int max_iterations, ContactRule rule) {
  require_backend(backend);
  if (!(min_gap > 0.0) || !std::isfinite(min_gap))
    throw InputError("resolve_contacts: min_gap must be positive, got " + std::to_string(min_gap));
  if (!(Lx > 0.0) || !(Lz > 0.0) || !(H > 0.0))
    throw InputError("resolve_contacts: Lx, Lz and H must be positive");
  if (max_iterations < 0) throw InputError("resolve_contacts: max_iterations must be >= 0");

  ContactStats st;
  const int nc = s.num_capsules(), nv = s.nodes_per_capsule();
  if (nc == 0) return st;

  // Translation-invariant data, computed once: centres, bounding radii, y extent.
  const CapsuleGeometry geo = compute_geometry(s, backend);
  const std::vector<double>& c0 = geo.centroid;
  std::vector<double> rmax(nc), ymin(nc), ymax(nc);
  capsule_bounds(backend, nc, nv, s.x.data(), s.y.data(), s.z.data(), c0.data(), rmax.data(), ymin.data(),
                 ymax.data());
  const MeshTopology topo = s.topology();

  PairGapLimits lim;
  lim.range = 2.0 * min_gap;  // pair gaps are searched (and reported) up to this distance
  lim.target = (1.0 + kMargin) * min_gap;
  lim.limit = (1.0 - kRoundoff) * min_gap;
  lim.min_alignment = kMinAlignment;
  const double target = lim.target, limit = lim.limit;
  std::vector<double> off(3 * static_cast<std::size_t>(nc), 0.0), centre(c0), disp(off.size());
  std::vector<int> pairs;
  std::vector<double> gap, need;
  // Event of each pushed pair / (capsule, wall), created at first detection.
  std::map<std::pair<int, int>, std::size_t> pair_event;
  std::vector<long> wall_event(2 * static_cast<std::size_t>(nc), -1);

  for (int iter = 0;; ++iter) {
    for (std::size_t i = 0; i < centre.size(); ++i) centre[i] = c0[i] + off[i];
    // Candidate pairs: bounding spheres (minimum image) closer than the search range. O(nc^2), cheap next to the
    // node checks for the capsule counts of this project.
    pairs.clear();
    for (int p = 0; p < nc; ++p)
      for (int q = p + 1; q < nc; ++q) {
        const double dx = min_image(centre[3 * p] - centre[3 * q], Lx), dy = centre[3 * p + 1] - centre[3 * q + 1],
                     dz = min_image(centre[3 * p + 2] - centre[3 * q + 2], Lz);
        const double reach = rmax[p] + rmax[q] + lim.range;
        if (dx * dx + dy * dy + dz * dz < reach * reach) {
          pairs.push_back(p);
          pairs.push_back(q);
        }
      }
    const int npair = static_cast<int>(pairs.size() / 2);
    gap.assign(npair, lim.range);
    need.assign(npair, 0.0);
    if (npair > 0)
      pair_gaps(backend, nc, topo, Vec3In{s.x.data(), s.y.data(), s.z.data()}, off.data(), centre.data(), rmax.data(),
                npair, pairs.data(), lim, Lx, Lz, gap.data(), need.data());
    double mg = std::numeric_limits<double>::infinity();
    bool violated = false;
    for (int p = 0; p < npair; ++p) {
      mg = std::min(mg, gap[p]);
      violated = violated || gap[p] < limit;
    }
    for (int k = 0; k < nc; ++k) {
      const double gb = ymin[k] + off[3 * k + 1], gt = H - (ymax[k] + off[3 * k + 1]);
      mg = std::min(mg, std::min(gb, gt));
      violated = violated || gb < limit || gt < limit;
    }
    if (iter == 0) st.initial_min_gap = mg;
    st.final_min_gap = mg;
    if (!violated) break;
    if (iter >= max_iterations) {
      st.converged = false;
      break;
    }

    // Pair pushes along the line of centres (Jacobi: all pairs from the same detection).
    std::fill(disp.begin(), disp.end(), 0.0);
    for (int p = 0; p < npair; ++p) {
      if (!(gap[p] < limit)) continue;
      const int P = pairs[2 * p], Q = pairs[2 * p + 1];
      double e[3];
      pair_push_direction(&centre[3 * P], &centre[3 * Q], Lx, Lz, e);
      // step: displacement of P along e (Q moves by -step e)
      const double step = rule == ContactRule::Amit ? -kRex * (1.0 - min_gap / std::max(gap[p], kAmitGapFloor))
                                                    : 0.5 * need[p];
      for (int d = 0; d < 3; ++d) {
        disp[3 * P + d] += step * e[d];
        disp[3 * Q + d] -= step * e[d];
      }
      ++st.pair_corrections;
      const auto ins = pair_event.emplace(std::make_pair(P, Q), st.events.size());
      if (ins.second) st.events.push_back({P, Q, -1, gap[p], 0.0, 0.0});
      ContactEvent& ev = st.events[ins.first->second];
      ev.dy_p += step * e[1];
      ev.dy_q -= step * e[1];
    }
    for (std::size_t i = 0; i < off.size(); ++i) off[i] += disp[i];

    // Wall pushes (D5), after the pair pushes so that a pair push never leaves a capsule in a wall.
    for (int k = 0; k < nc; ++k)
      for (int w = 0; w < 2; ++w) {
        const double g = w == 0 ? ymin[k] + off[3 * k + 1] : H - (ymax[k] + off[3 * k + 1]);
        if (!(g < limit)) continue;
        const double dy = w == 0 ? target - g : g - target;
        off[3 * k + 1] += dy;
        ++st.wall_corrections;
        long& ie = wall_event[2 * static_cast<std::size_t>(k) + w];
        if (ie < 0) {
          ie = static_cast<long>(st.events.size());
          st.events.push_back({k, -1, w, g, 0.0, 0.0});
        }
        st.events[static_cast<std::size_t>(ie)].dy_p += dy;
      }
    ++st.iterations;
  }
  for (const ContactEvent& ev : st.events) ++(ev.wall < 0 ? st.pair_events : st.wall_events);

  // Apply the accumulated translations once, as a kernel over the nodes (capsules without one are left
  // bit-identical). Detection and correction thus read and write the node arrays only through kernels: on the device
  // backend they stay resident, and only per-capsule data (centres, bounds, gaps, offsets) crosses (docs/device.md).
  bool moved = false;
  for (int k = 0; k < nc; ++k) {
    const double ox = off[3 * k], oy = off[3 * k + 1], oz = off[3 * k + 2];
    if (ox == 0.0 && oy == 0.0 && oz == 0.0) continue;
    st.max_displacement = std::max(st.max_displacement, std::sqrt(ox * ox + oy * oy + oz * oz));
    moved = true;
  }
  if (moved) translate_capsules(backend, nc, nv, off.data(), s.x.data(), s.y.data(), s.z.data());
  return st;
}

ClosingLimits closing_limits(const CapsuleState& s, const std::vector<double>& centroid, const double* ux,
                             const double* uy, const double* uz, double Lx, double Lz, double H, double range,
                             double floor, Backend backend) {
  ClosingLimits out;
  const int nc = s.num_capsules(), nv = s.nodes_per_capsule();
  if (nc == 0) return out;
  std::vector<double> rmax(nc), ymin(nc), ymax(nc);
  capsule_bounds(backend, nc, nv, s.x.data(), s.y.data(), s.z.data(), centroid.data(), rmax.data(), ymin.data(),
                 ymax.data());
  std::vector<int> pairs;
  for (int p = 0; p < nc; ++p)
    for (int q = p + 1; q < nc; ++q) {
      const double dx = min_image(centroid[3 * p] - centroid[3 * q], Lx), dy = centroid[3 * p + 1] - centroid[3 * q + 1],
                   dz = min_image(centroid[3 * p + 2] - centroid[3 * q + 2], Lz);
      const double reach = rmax[p] + rmax[q] + range;
      if (dx * dx + dy * dy + dz * dz < reach * reach) {
        pairs.push_back(p);
        pairs.push_back(q);
      }
    }
  const int npair = static_cast<int>(pairs.size() / 2);
  std::vector<double> gap(std::max(npair, nc)), tmin(gap.size());
  if (npair > 0) {
    pair_closing(backend, nc, s.topology(), Vec3In{s.x.data(), s.y.data(), s.z.data()}, Vec3In{ux, uy, uz},
                 centroid.data(), rmax.data(), npair, pairs.data(), ClosingThresholds{range, floor}, Lx, Lz, gap.data(),
                 tmin.data());
    for (int p = 0; p < npair; ++p) {
      if (gap[p] < range) out.pair_gap = std::min(out.pair_gap, gap[p]);
      if (tmin[p] < 1e300) out.time_to_close = std::min(out.time_to_close, tmin[p]);
    }
  }
  // Only capsules whose extent reaches within range of a wall have wall gaps to look at.
  bool near_wall = false;
  for (int k = 0; k < nc; ++k) near_wall = near_wall || ymin[k] < range || ymax[k] > H - range;
  if (near_wall) {
    wall_closing(backend, nc, nv, s.y.data(), uy, H, range, floor, gap.data(), tmin.data());
    for (int k = 0; k < nc; ++k) {
      if (gap[k] < range) out.wall_gap = std::min(out.wall_gap, gap[k]);
      if (tmin[k] < 1e300) out.time_to_close = std::min(out.time_to_close, tmin[k]);
    }
  }
  return out;
}

}  // namespace capsflow
