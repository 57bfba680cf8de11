#include "host/simulation.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "host/backend_select.hpp"
#include "host/errors.hpp"
#include "host/h5_file.hpp"
#include "host/stopwatch.hpp"
#include "kernels/capsule_geometry.hpp"
#include "kernels/contact.hpp"
#include "kernels/ggem_kernels.hpp"

namespace capsflow {

const char* stop_reason_name(StopReason r) {
  switch (r) {
    case StopReason::None: return "none";
    case StopReason::NotFinite: return "not-finite";
    case StopReason::LeftSlit: return "left-slit";
    case StopReason::DtBelowFloor: return "dt-below-floor";
    case StopReason::MeshTooLarge: return "mesh-too-large";
  }
  return "?";
}

namespace {

bool all_finite(const std::vector<double>& v) {
  for (double a : v)
    if (!std::isfinite(a)) return false;
  return true;
}

// D1: Gs = mu gammadot a / Ca. CapsuleState sets Gs = a / Ca', so it is given Ca' = Ca / (mu gammadot).
double state_ca(const Config& c, double ca) { return ca / (c.domain.viscosity * c.flow.shear_rate); }

// Largest element bounding radius (centroid to vertex) over all capsules: the cell list of the local part needs
// Lx, Lz > 2 (cutoff + it).
double max_element_radius(const CapsuleState& s) {
  const int nc = s.num_capsules(), nv = s.nodes_per_capsule(), nt = s.triangles_per_capsule();
  const int* tri = s.mesh().tri.data();
  double r2 = 0.0;
  for (int k = 0; k < nc; ++k) {
    const std::size_t o = static_cast<std::size_t>(k) * nv;
    for (int e = 0; e < nt; ++e) {
      const std::size_t a = o + tri[3 * e], b = o + tri[3 * e + 1], c = o + tri[3 * e + 2];
      const double cx = (s.x[a] + s.x[b] + s.x[c]) / 3, cy = (s.y[a] + s.y[b] + s.y[c]) / 3,
                   cz = (s.z[a] + s.z[b] + s.z[c]) / 3;
      for (std::size_t v : {a, b, c}) {
        const double dx = s.x[v] - cx, dy = s.y[v] - cy, dz = s.z[v] - cz;
        r2 = std::max(r2, dx * dx + dy * dy + dz * dz);
      }
    }
  }
  return std::sqrt(r2);
}

}  // namespace

Simulation::Simulation(const Config& cfg)
    : cfg_(cfg),
      s_(cfg.capsules.mesh_level, cfg.capsules.membrane),
      velocity_(cfg.domain, cfg.ggem, cfg.run.backend) {
  validate_run_config(cfg_);
  placements_ = place_capsules(cfg_);
  build_state();
}

Simulation::Simulation(const Config& cfg, const H5File& ck)
    : cfg_(cfg),
      s_(cfg.capsules.mesh_level, cfg.capsules.membrane),
      velocity_(cfg.domain, cfg.ggem, cfg.run.backend) {
  validate_run_config(cfg_);
  const std::string where = ck.path().string() + ": ";
  auto need = [&](const std::string& p) {
    if (!ck.exists(p)) throw InputError(where + "not a capsflow checkpoint (missing " + p + ")");
  };
  need("/state/initial_centres");
  need("/state/positions");
  need("/state/u_previous");
  const auto centres = ck.read<double>("/state/initial_centres");
  const auto species = ck.read<std::int64_t>("/state/species");
  const auto pinned = ck.read<std::int64_t>("/state/pinned");
  const std::size_t np = species.data.size();
  if (centres.data.size() != 3 * np || pinned.data.size() != np)
    throw InputError(where + "inconsistent /state arrays");
  placements_.resize(np);
  for (std::size_t k = 0; k < np; ++k) {
    placements_[k].center = {centres.data[3 * k], centres.data[3 * k + 1], centres.data[3 * k + 2]};
    placements_[k].species = static_cast<int>(species.data[k]);
    placements_[k].pinned = pinned.data[k] != 0;
    if (placements_[k].species < 0 || placements_[k].species >= static_cast<int>(cfg_.species.size()))
      throw InputError(where + "capsule species out of range of the stored configuration");
  }
  build_state();

  const auto pos = ck.read<double>("/state/positions");
  const auto up = ck.read<double>("/state/u_previous");
  const std::size_t n = s_.x.size();
  if (pos.data.size() != 3 * n || up.data.size() != 3 * n)
    throw InputError(where + "/state/positions does not match the mesh level and capsule count");
  for (std::size_t i = 0; i < n; ++i) {
    s_.x[i] = pos.data[3 * i];
    s_.y[i] = pos.data[3 * i + 1];
    s_.z[i] = pos.data[3 * i + 2];
    uxp_[i] = up.data[3 * i];
    uyp_[i] = up.data[3 * i + 1];
    uzp_[i] = up.data[3 * i + 2];
  }
  const auto img = ck.read<std::int64_t>("/state/image");
  const auto pc = ck.read<double>("/state/pin_centres");
  if (img.data.size() != 2 * np || pc.data.size() != 3 * np) throw InputError(where + "inconsistent /state arrays");
  image_ = img.data;
  pin_centre_ = pc.data;
  time_ = ck.attribute<double>("/state", "time");
  step_ = ck.attribute<std::int64_t>("/state", "step");
  dt_prev_ = ck.attribute<double>("/state", "dt_previous");
  have_history_ = ck.attribute<std::int64_t>("/state", "have_history") != 0;
  contact_corrections_ = static_cast<long>(ck.attribute<std::int64_t>("/state", "contact_corrections"));
  steps_with_contacts_ = static_cast<long>(ck.attribute<std::int64_t>("/state", "steps_with_contacts"));
  unconverged_contacts_ = static_cast<long>(ck.attribute<std::int64_t>("/state", "unconverged_contacts"));
}

void Simulation::build_state() {
  // One CapsuleState species per configured species, in file order (species index = [[species]] index).
  for (const SpeciesSpec& sp : cfg_.species) s_.add_species(state_ca(cfg_, sp.ca));
  ca_min_ = std::numeric_limits<double>::infinity();
  const std::size_t np = placements_.size();
  pinned_.assign(np, 0);
  pin_centre_.assign(3 * np, 0.0);
  image_.assign(2 * np, 0);
  for (std::size_t k = 0; k < np; ++k) {
    const CapsulePlacement& p = placements_[k];
    s_.add_capsule(p.center, cfg_.capsules.radius, p.species);
    ca_min_ = std::min(ca_min_, cfg_.species[static_cast<std::size_t>(p.species)].ca);
    pinned_[k] = p.pinned ? 1 : 0;
  }
  // The pinned centre is the centre of mass of the initial (discrete) capsule, not the nominal centre.
  const CapsuleGeometry g = compute_geometry(s_, Backend::Serial);
  for (std::size_t k = 0; k < np; ++k)
    for (int c = 0; c < 3; ++c) pin_centre_[3 * k + c] = g.centroid[3 * k + c];
  volume0_ = g.volume;
  const std::size_t n = s_.x.size();
  uxp_.assign(n, 0.0);
  uyp_.assign(n, 0.0);
  uzp_.assign(n, 0.0);
}

void Simulation::evaluate() {
  if (evaluated_) return;
  const Backend b = cfg_.run.backend;
  auto t0 = std::chrono::steady_clock::now();
  s_.compute_membrane_forces(b);
  timings_.forces = seconds_since(t0);
  velocity_.node_velocities(s_, cfg_.flow, ux_, uy_, uz_);
  const CapsuleVelocityTimings& vt = velocity_.last_timings();
  timings_.local_nodes = vt.local_nodes;
  timings_.local_walls = vt.local_walls;
  timings_.global = vt.global;
  timings_.velocity_total = vt.total;
  compute_mean_velocity(s_, b, ux_, uy_, uz_, U_, omega_);
  evaluated_ = true;
}

double Simulation::min_node_distance(bool* between) const {
  const CapsuleGeometry g = compute_geometry(s_, Backend::Serial);
  double h = g.global_min_edge;
  bool from_pair = false;
  const int nc = s_.num_capsules(), nv = s_.nodes_per_capsule();
  const double Lx = cfg_.domain.Lx, Lz = cfg_.domain.Lz;
  // Node-mean centre and bounding radius per capsule: a pair can hold a node pair closer than h only if
  // |c_p - c_q| - r_p - r_q < h.
  const std::size_t ncs = static_cast<std::size_t>(nc);
  std::vector<double> c(3 * ncs), r(ncs), ymin(ncs), ymax(ncs);
  for (std::size_t k = 0; k < ncs; ++k) {
    const std::size_t o = k * nv;
    node_mean(nv, &s_.x[o], &s_.y[o], &s_.z[o], c[3 * k], c[3 * k + 1], c[3 * k + 2]);
  }
  capsule_bounds(Backend::Serial, nc, nv, s_.x.data(), s_.y.data(), s_.z.data(), c.data(), r.data(), ymin.data(),
                 ymax.data());
  std::vector<int> pairs;
  for (int p = 0; p < nc; ++p)
    for (int q = p + 1; q < nc; ++q) {
      const double dx = min_image(c[3 * p] - c[3 * q], Lx), dy = c[3 * p + 1] - c[3 * q + 1],
                   dz = min_image(c[3 * p + 2] - c[3 * q + 2], Lz);
      if (std::sqrt(dx * dx + dy * dy + dz * dz) - r[p] - r[q] < h) {
        pairs.push_back(p);
        pairs.push_back(q);
      }
    }
  const long npair = static_cast<long>(pairs.size() / 2);
  double hp = std::numeric_limits<double>::infinity();
  // min is exact and order-independent: every backend gives the same value.
#pragma omp parallel for reduction(min : hp) schedule(dynamic) if (cfg_.run.backend != Backend::Serial)
  for (long k = 0; k < npair; ++k) {
    const std::size_t op = static_cast<std::size_t>(pairs[2 * k]) * nv, oq = static_cast<std::size_t>(pairs[2 * k + 1]) * nv;
    double best = std::numeric_limits<double>::infinity();
    for (int i = 0; i < nv; ++i)
      for (int j = 0; j < nv; ++j) {
        const double dx = min_image(s_.x[op + i] - s_.x[oq + j], Lx), dy = s_.y[op + i] - s_.y[oq + j],
                     dz = min_image(s_.z[op + i] - s_.z[oq + j], Lz);
        best = std::min(best, dx * dx + dy * dy + dz * dz);
      }
    hp = std::min(hp, best);
  }
  hp = std::sqrt(hp);
  if (hp < h) {
    h = hp;
    from_pair = true;
  }
  if (between) *between = from_pair;
  return h;
}

StepInfo Simulation::advance() {
  evaluate();
  StepInfo info;
  const std::size_t n = s_.x.size();
  if (!all_finite(ux_) || !all_finite(uy_) || !all_finite(uz_)) {
    info.stop = StopReason::NotFinite;
    info.message = "a node velocity is not finite at strain " + std::to_string(time_) + " (step " +
                   std::to_string(step_) + ")";
    return info;
  }

  auto t0 = std::chrono::steady_clock::now();
  info.h = min_node_distance(&info.h_between_capsules);
  info.dt = cfg_.time.cfl * ca_min_ * info.h;  // D8, strain units
  timings_.step_size = seconds_since(t0);
  if (!(info.dt >= cfg_.time.dt_floor)) {
    info.stop = StopReason::DtBelowFloor;
    info.message = "the time step " + std::to_string(info.dt) + " fell below [time] dt_floor = " +
                   std::to_string(cfg_.time.dt_floor) + " (h = " + std::to_string(info.h) +
                   (info.h_between_capsules ? " between two capsules" : " inside a capsule") + ") at strain " +
                   std::to_string(time_);
    return info;
  }

  t0 = std::chrono::steady_clock::now();
  xs_ = s_.x;
  ys_ = s_.y;
  zs_ = s_.z;
  // Variable-step AB2 (method-spec 8.1); physical time step dt / gammadot.
  const double dtp = info.dt / cfg_.flow.shear_rate;
  double a = 1.0, b = 0.0;
  if (have_history_) {
    const double r = info.dt / dt_prev_;
    a = 1.0 + 0.5 * r;
    b = -0.5 * r;
  }
  for (std::size_t i = 0; i < n; ++i) {
    s_.x[i] += dtp * (a * ux_[i] + b * uxp_[i]);
    s_.y[i] += dtp * (a * uy_[i] + b * uyp_[i]);
    s_.z[i] += dtp * (a * uz_[i] + b * uzp_[i]);
  }
  timings_.update = seconds_since(t0);

  t0 = std::chrono::steady_clock::now();
  info.contact = resolve_contacts(s_, cfg_.domain.Lx, cfg_.domain.Lz, cfg_.domain.H, cfg_.time.min_gap,
                                  cfg_.run.backend);
  timings_.contact = seconds_since(t0);
  if (cfg_.capsules.volume_correction) correct_volumes();
  pin_and_wrap();

  // Check before keeping: a bad step leaves x^n in place for the final checkpoint.
  StopReason bad = StopReason::None;
  std::string why;
  if (!all_finite(s_.x) || !all_finite(s_.y) || !all_finite(s_.z)) {
    bad = StopReason::NotFinite;
    why = "a node position became non-finite";
  } else {
    const double H = cfg_.domain.H;
    for (std::size_t i = 0; i < n; ++i)
      if (s_.y[i] < 0.0 || s_.y[i] > H) {
        bad = StopReason::LeftSlit;
        why = "capsule " + std::to_string(i / static_cast<std::size_t>(s_.nodes_per_capsule())) +
              " left the slit (node at y = " + std::to_string(s_.y[i]) + ", walls at 0 and " + std::to_string(H) +
              "; contact control " + (info.contact.converged ? "converged" : "did not converge") + ")";
        break;
      }
  }
  if (bad == StopReason::None) {
    const double re = max_element_radius(s_), cutoff = velocity_.ggem().grid().cutoff;
    if (!(2.0 * (cutoff + re) < std::min(cfg_.domain.Lx, cfg_.domain.Lz))) {
      bad = StopReason::MeshTooLarge;
      why = "a membrane element grew to radius " + std::to_string(re) +
            " (the local sums need Lx, Lz > 2 (cutoff + element radius); the mesh is blowing up or the box is too "
            "small)";
    }
  }
  if (bad != StopReason::None) {
    s_.x.swap(xs_);
    s_.y.swap(ys_);
    s_.z.swap(zs_);
    info.stop = bad;
    info.message = why + " in the step from strain " + std::to_string(time_) + " (step " + std::to_string(step_) +
                   ", dt " + std::to_string(info.dt) + ")";
    return info;
  }

  const long corr = info.contact.pair_corrections + info.contact.wall_corrections;
  contact_corrections_ += corr;
  if (corr > 0) ++steps_with_contacts_;
  if (!info.contact.converged) ++unconverged_contacts_;
  uxp_.swap(ux_);
  uyp_.swap(uy_);
  uzp_.swap(uz_);
  have_history_ = true;
  dt_prev_ = info.dt;
  time_ += info.dt;
  ++step_;
  evaluated_ = false;
  return info;
}

void Simulation::pin_and_wrap() {
  const int nc = s_.num_capsules(), nv = s_.nodes_per_capsule();
  bool any_pinned = false;
  for (char p : pinned_) any_pinned = any_pinned || p;
  if (any_pinned) {
    // D10: translate a pinned capsule so that its centre of mass is back where it started.
    const CapsuleGeometry g = compute_geometry(s_, Backend::Serial);
    for (int k = 0; k < nc; ++k) {
      if (!pinned_[k]) continue;
      const std::size_t o = static_cast<std::size_t>(k) * nv;
      const double dx = pin_centre_[3 * k] - g.centroid[3 * k], dy = pin_centre_[3 * k + 1] - g.centroid[3 * k + 1],
                   dz = pin_centre_[3 * k + 2] - g.centroid[3 * k + 2];
      for (int i = 0; i < nv; ++i) {
        s_.x[o + i] += dx;
        s_.y[o + i] += dy;
        s_.z[o + i] += dz;
      }
    }
  }
  // Keep every capsule's node mean inside the periodic box, so positions stay O(L) on long runs.
  const double L[2] = {cfg_.domain.Lx, cfg_.domain.Lz};
  std::vector<double>* X[2] = {&s_.x, &s_.z};
  for (int k = 0; k < nc; ++k) {
    const std::size_t o = static_cast<std::size_t>(k) * nv;
    double mx, my, mz;
    node_mean(nv, &s_.x[o], &s_.y[o], &s_.z[o], mx, my, mz);
    const double mean[2] = {mx, mz};
    for (int d = 0; d < 2; ++d) {
      std::vector<double>& v = *X[d];
      const double shift = std::floor(mean[d] / L[d]);
      if (shift == 0.0) continue;
      for (int i = 0; i < nv; ++i) v[o + i] -= shift * L[d];
      image_[2 * k + d] += static_cast<std::int64_t>(shift);
    }
  }
}

void Simulation::correct_volumes() {
  // Newton on V(delta) for a displacement delta along the node normals n_i = w_i / |w_i|, w_i the sum of the area
  // vectors of the node's triangles: dV/d(x_i) = w_i / 3, so dV/d(delta) = sum_i |w_i| / 3 exactly (using the area
  // A instead leaves a mesh-dependent fraction of the deficit, 15 % at level 1). Two iterations leave O(deficit^3).
  const int nc = s_.num_capsules(), nv = s_.nodes_per_capsule(), nt = s_.triangles_per_capsule();
  const int* tri = s_.mesh().tri.data();
  std::vector<double> w(3 * static_cast<std::size_t>(nv));
  for (int it = 0; it < 2; ++it) {
    const CapsuleGeometry g = compute_geometry(s_, Backend::Serial);
    for (int k = 0; k < nc; ++k) {
      const std::size_t o = static_cast<std::size_t>(k) * nv;
      std::fill(w.begin(), w.end(), 0.0);
      for (int e = 0; e < nt; ++e) {
        const int a = tri[3 * e], b = tri[3 * e + 1], c = tri[3 * e + 2];
        const double ux = s_.x[o + b] - s_.x[o + a], uy = s_.y[o + b] - s_.y[o + a], uz = s_.z[o + b] - s_.z[o + a];
        const double vx = s_.x[o + c] - s_.x[o + a], vy = s_.y[o + c] - s_.y[o + a], vz = s_.z[o + c] - s_.z[o + a];
        const double ax = 0.5 * (uy * vz - uz * vy), ay = 0.5 * (uz * vx - ux * vz), az = 0.5 * (ux * vy - uy * vx);
        for (int q : {a, b, c}) {
          w[3 * q] += ax;
          w[3 * q + 1] += ay;
          w[3 * q + 2] += az;
        }
      }
      double dV = 0.0;
      for (int i = 0; i < nv; ++i) dV += std::sqrt(w[3 * i] * w[3 * i] + w[3 * i + 1] * w[3 * i + 1] + w[3 * i + 2] * w[3 * i + 2]);
      dV /= 3.0;
      const double delta = (volume0_[static_cast<std::size_t>(k)] - g.volume[static_cast<std::size_t>(k)]) / dV;
      for (int i = 0; i < nv; ++i) {
        const double len = std::sqrt(w[3 * i] * w[3 * i] + w[3 * i + 1] * w[3 * i + 1] + w[3 * i + 2] * w[3 * i + 2]);
        s_.x[o + i] += delta * w[3 * i] / len;
        s_.y[o + i] += delta * w[3 * i + 1] / len;
        s_.z[o + i] += delta * w[3 * i + 2] / len;
      }
    }
  }
}

CapsuleGeometry Simulation::geometry() const { return compute_geometry(s_, Backend::Serial); }

std::vector<double> Simulation::unwrapped_centroids(const CapsuleGeometry& g) const {
  std::vector<double> c = g.centroid;
  for (std::size_t k = 0; k < image_.size() / 2; ++k) {
    c[3 * k] += static_cast<double>(image_[2 * k]) * cfg_.domain.Lx;
    c[3 * k + 2] += static_cast<double>(image_[2 * k + 1]) * cfg_.domain.Lz;
  }
  return c;
}

void Simulation::write_state(H5File& f) const {
  const std::size_t np = placements_.size(), n = s_.x.size();
  std::vector<double> centres(3 * np), pos(3 * n), up(3 * n);
  std::vector<std::int64_t> species(np), pinned(np);
  for (std::size_t k = 0; k < np; ++k) {
    for (int c = 0; c < 3; ++c) centres[3 * k + c] = placements_[k].center[c];
    species[k] = placements_[k].species;
    pinned[k] = placements_[k].pinned ? 1 : 0;
  }
  for (std::size_t i = 0; i < n; ++i) {
    pos[3 * i] = s_.x[i];
    pos[3 * i + 1] = s_.y[i];
    pos[3 * i + 2] = s_.z[i];
    up[3 * i] = uxp_[i];
    up[3 * i + 1] = uyp_[i];
    up[3 * i + 2] = uzp_[i];
  }
  // The reference shapes are those of add_capsule at the initial centres: storing the centres restores them
  // bit for bit.
  f.write("/state/initial_centres", {np, 3}, centres);
  f.write("/state/species", {np}, species);
  f.write("/state/pinned", {np}, pinned);
  f.write("/state/pin_centres", {np, 3}, pin_centre_);
  f.write("/state/image", {np, 2}, image_);
  f.write("/state/positions", {n, 3}, pos);
  f.write("/state/u_previous", {n, 3}, up);
  f.set_attribute("/state", "time", time_);
  f.set_attribute("/state", "step", step_);
  f.set_attribute("/state", "dt_previous", dt_prev_);
  f.set_attribute("/state", "have_history", have_history_ ? 1 : 0);
  f.set_attribute("/state", "contact_corrections", static_cast<std::int64_t>(contact_corrections_));
  f.set_attribute("/state", "steps_with_contacts", static_cast<std::int64_t>(steps_with_contacts_));
  f.set_attribute("/state", "unconverged_contacts", static_cast<std::int64_t>(unconverged_contacts_));
}

}  // namespace capsflow
