// The implementation of constraints.hpp: the constraints on the positions after a step (volume, contact, pinning).
#include "host/physics/constraints.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <utility>

#include "host/base/printable.hpp"
#include "host/base/stopwatch.hpp"
#include "host/physics/contact.hpp"
#include "kernels/capsule_geometry.hpp"
#include "kernels/step_update.hpp"

namespace capsflow {
namespace {

// A double in a message: %g, never %f (a 1e300 would print as 300 digits).
std::string num(double v) { return format_significant(v, 6); }

}  // namespace

void VolumeCorrection::apply(ConstraintContext& c, StepInfo&) {
  // Newton on V(delta) for a displacement delta along the node normals n_i = w_i / |w_i|, w_i = dV/dx_i:
  // dV/d(delta) = sum_i |w_i| exactly (using the area A instead leaves a mesh-dependent fraction of the deficit,
  // 15 % at level 1). Two iterations leave O(deficit^3).
  CapsuleState& s = c.s;
  const int nc = s.num_capsules(), nv = s.nodes_per_capsule();
  const Backend gb = c.geometry_backend;
  const TriMesh& m = s.mesh();
  for (auto* v : {&c.w.x, &c.w.y, &c.w.z}) c.ws.device_overwrite(*v);
  for (int it = 0; it < 2; ++it) {
    const CapsuleGeometry g = compute_geometry(s, gb);
    volume_gradient(gb, nc, nv, m.tri.data(), m.inc_offsets.data(), m.inc_tri.data(), s.x.data(), s.y.data(),
                    s.z.data(), c.w.x.data(), c.w.y.data(), c.w.z.data());
    volume_correction_step(gb, nc, nv, volume0_.data(), g.volume.data(), c.w.x.data(), c.w.y.data(), c.w.z.data(),
                           s.x.data(), s.y.data(), s.z.data());
  }
}

void ContactControl::apply(ConstraintContext& c, StepInfo& info) {
  const auto t0 = std::chrono::steady_clock::now();
  const Config& cfg = *cfg_;
  info.contact = resolve_contacts(c.s, cfg.domain.Lx, cfg.domain.Lz, cfg.domain.H, cfg.time.min_gap, c.backend);
  c.timings.contact = seconds_since(t0);
}

void ContactControl::commit(const StepInfo& info, double time) {
  const long corr = info.contact.pair_corrections + info.contact.wall_corrections;
  corrections_ += corr;
  if (corr > 0) ++steps_with_contacts_;
  if (!info.contact.converged) ++unconverged_;
  for (const ContactEvent& e : info.contact.events) {
    events_.push_back({time, e.p, e.wall >= 0 ? -(e.wall + 1) : e.q, e.gap_before, e.dy_p, e.dy_q});
    ++events_total_;
  }
}

void ContactControl::save(SimulationSnapshot& st) const {
  st.contact_corrections = corrections_;
  st.steps_with_contacts = steps_with_contacts_;
  st.unconverged_contacts = unconverged_;
  st.contact_events = events_total_;
}

void ContactControl::restore(const SimulationSnapshot& st) {
  corrections_ = static_cast<long>(st.contact_corrections);
  steps_with_contacts_ = static_cast<long>(st.steps_with_contacts);
  unconverged_ = static_cast<long>(st.unconverged_contacts);
  events_total_ = static_cast<long>(st.contact_events);
}

PinAndWrap::PinAndWrap(const Config& cfg, std::vector<char> pinned, std::vector<double> centre)
    : Lx_(cfg.domain.Lx), Lz_(cfg.domain.Lz), pinned_(std::move(pinned)), centre_(std::move(centre)),
      image_(2 * pinned_.size(), 0) {}

void PinAndWrap::apply(ConstraintContext& c, StepInfo&) {
  CapsuleState& s = c.s;
  const int nc = s.num_capsules(), nv = s.nodes_per_capsule();
  const Backend gb = c.geometry_backend;
  // Per-capsule decisions on the host (3 doubles a capsule come back), node updates as kernels.
  std::vector<double> off(3 * static_cast<std::size_t>(nc), 0.0);
  bool any_pinned = false, any = false;
  for (char p : pinned_) any_pinned = any_pinned || p;
  if (any_pinned) {
    // D10: translate a pinned capsule so that its centre of mass is back where it started.
    const CapsuleGeometry g = compute_geometry(s, gb);
    for (int k = 0; k < nc; ++k) {
      if (!pinned_[k]) continue;
      for (int d = 0; d < 3; ++d) off[3 * k + d] = centre_[3 * k + d] - g.centroid[3 * k + d];
    }
    translate_capsules(gb, nc, nv, off.data(), s.x.data(), s.y.data(), s.z.data());
  }
  // Keep every capsule's node mean inside the periodic box, so positions stay O(L) on long runs.
  const double L[2] = {Lx_, Lz_};
  std::vector<double> mean(3 * static_cast<std::size_t>(nc));
  capsule_node_means(gb, nc, nv, s.x.data(), s.y.data(), s.z.data(), mean.data());
  for (int k = 0; k < nc; ++k)
    for (int d = 0; d < 2; ++d) {
      const int a = 2 * d;  // x or z
      const double shift = std::floor(mean[3 * k + a] / L[d]);
      off[3 * k + a] = -(shift * L[d]);  // x + -(s L) is x - s L exactly
      off[3 * k + 1] = 0.0;
      if (shift == 0.0) continue;
      image_[2 * k + d] += static_cast<std::int64_t>(shift);
      any = true;
    }
  if (any) translate_capsules(gb, nc, nv, off.data(), s.x.data(), s.y.data(), s.z.data());
}

std::vector<double> PinAndWrap::unwrapped(const std::vector<double>& centroid) const {
  std::vector<double> c = centroid;
  for (std::size_t k = 0; k < image_.size() / 2; ++k) {
    c[3 * k] += static_cast<double>(image_[2 * k]) * Lx_;
    c[3 * k + 2] += static_cast<double>(image_[2 * k + 1]) * Lz_;
  }
  return c;
}

void PinAndWrap::save(SimulationSnapshot& st) const {
  st.pin_centres = centre_;
  st.image = image_;
}

void PinAndWrap::restore(const SimulationSnapshot& st) {
  image_ = st.image;
  if (!st.pin_centres.empty()) centre_ = st.pin_centres;  // empty: keep the placement's (a start from a frame)
}

std::vector<StepCheck> standard_step_checks() {
  std::vector<StepCheck> checks;
  // Reductions on the device: only their scalars come back (and y when a node has left, for the message).
  checks.push_back([](StepCheckContext& c, const StepInfo&, std::string& why) {
    c.ws.note_scalar_results(1);
    if (all_finite3(c.backend, c.s.x.size(), c.s.x.data(), c.s.y.data(), c.s.z.data())) return StopReason::None;
    why = "a node position became non-finite";
    return StopReason::NotFinite;
  });
  checks.push_back([](StepCheckContext& c, const StepInfo& info, std::string& why) {
    const double H = c.cfg.domain.H;
    c.ws.note_scalar_results(1);
    const long i = first_outside(c.backend, c.s.x.size(), c.s.y.data(), 0.0, H);
    if (i < 0) return StopReason::None;
    c.ws.host_read(c.s.y);
    why = "capsule " + std::to_string(static_cast<std::size_t>(i) / static_cast<std::size_t>(c.s.nodes_per_capsule())) +
          " left the slit (node at y = " + num(c.s.y[static_cast<std::size_t>(i)]) + ", walls at 0 and " + num(H) +
          "; contact control " + (info.contact.converged ? "converged" : "did not converge") + ")";
    return StopReason::LeftSlit;
  });
  checks.push_back([](StepCheckContext& c, const StepInfo&, std::string& why) {
    const CapsuleState& s = c.s;
    c.ws.note_scalar_results(1);
    const double re = max_element_radius(c.geometry_backend, s.num_capsules(), s.nodes_per_capsule(),
                                         s.triangles_per_capsule(), s.mesh().tri.data(), s.x.data(), s.y.data(),
                                         s.z.data());
    if (2.0 * (c.cutoff + re) < std::min(c.cfg.domain.Lx, c.cfg.domain.Lz)) return StopReason::None;
    why = "a membrane element grew to radius " + num(re) +
          " (the local sums need Lx, Lz > 2 (cutoff + element radius); the mesh is blowing up or the box is too "
          "small)";
    return StopReason::MeshTooLarge;
  });
  checks.push_back([](StepCheckContext& c, const StepInfo& info, std::string& why) {
    // A contact control that leaves overlaps would let the next step start from them (T5 of the step-rule issue).
    if (info.contact.converged) return StopReason::None;
    why = "the contact control did not reach min_gap = " + num(c.cfg.time.min_gap) + " (smallest gap " +
          num(info.contact.final_min_gap) + " after " + std::to_string(info.contact.iterations) + " iterations)";
    return StopReason::ContactFailed;
  });
  return checks;
}

}  // namespace capsflow
