#include "host/physics/simulation.hpp"

#include <cstdio>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "host/base/backend_select.hpp"
#include "host/base/errors.hpp"
#include "host/base/printable.hpp"
#include "host/base/stopwatch.hpp"
#include "host/physics/key_blame.hpp"
#include "host/physics/step_watch.hpp"
#include "kernels/capsule_geometry.hpp"
#include "kernels/contact.hpp"
#include "kernels/ggem_kernels.hpp"
#include "kernels/slab_volume.hpp"
#include "kernels/slit_cells.hpp"
#include "kernels/step_update.hpp"

namespace capsflow {

const char* stop_reason_name(StopReason r) {
  switch (r) {
    case StopReason::None: return "none";
    case StopReason::NotFinite: return "not-finite";
    case StopReason::LeftSlit: return "left-slit";
    case StopReason::DtBelowFloor: return "dt-below-floor";
    case StopReason::MeshTooLarge: return "mesh-too-large";
    case StopReason::ContactFailed: return "contact-failed";
    case StopReason::SolveNotConverged: return "gmres-not-converged";
  }
  return "?";
}

const char* step_limit_name(StepLimit l) {
  switch (l) {
    case StepLimit::Membrane: return "membrane";
    case StepLimit::NearContact: return "near-contact";
    case StepLimit::Collision: return "collision";
    case StepLimit::Ratio: return "ratio";
    case StepLimit::PaperGap: return "paper-gap";
  }
  return "?";
}

namespace {

// A double in a message: %g, never %f (a 1e300 would print as 300 digits).
std::string num(double v) { return format_significant(v, 6); }

int imposed_flow_code(FlowType t) {
  switch (t) {
    case FlowType::Poiseuille: return kImposedPoiseuille;
    case FlowType::Shear: return kImposedShear;
    case FlowType::None: return kImposedNone;
  }
  return kImposedNone;
}

bool all_finite(const std::vector<double>& v) {
  for (double x : v)
    if (!std::isfinite(x)) return false;
  return true;
}

// Why an interface-velocity solve from finite data did not converge, naming the key: a non-finite residual is the
// operator's overflow (the most extreme viscosity ratio: ((1 + lambda)/2) u - (1 - lambda) K[u]), which no cap
// mends; a finite one is the cap's.
std::string gmres_failure(const Config& c, const GmresResult& g) {
  if (std::isfinite(g.residual))
    return "[gmres] max_iterations = " + std::to_string(c.gmres.max_iterations) + ": the interface-velocity solve " +
           "reaches the relative residual " + num(g.residual) + " after " + std::to_string(g.iterations) +
           " operator applications, not [gmres] tolerance = " + num(c.gmres.tolerance);
  std::size_t worst = 0;
  for (std::size_t i = 1; i < c.species.size(); ++i)
    if (std::abs(std::log(c.species[i].viscosity_ratio)) > std::abs(std::log(c.species[worst].viscosity_ratio)))
      worst = i;
  return "[[species]] " + std::to_string(worst + 1) + " viscosity_ratio = " + num(c.species[worst].viscosity_ratio) +
         ": the interface-velocity solve's residual is not finite after " + std::to_string(g.iterations) +
         " operator applications (the operator ((1 + lambda)/2) u - (1 - lambda) K[u] overflows); expected a "
         "viscosity ratio whose operator is finite in double precision";
}

// D1: Gs = mu gammadot a / Ca. CapsuleState sets Gs = a / Ca', so it is given Ca' = Ca / (mu gammadot).
double state_ca(const Config& c, double ca) { return ca / (c.domain.viscosity * c.flow.shear_rate); }

}  // namespace

Simulation::Simulation(const Config& cfg)
    : cfg_(cfg),
      s_(cfg.capsules.mesh_level, cfg.capsules.membrane),
      velocity_(cfg.domain, cfg.ggem, cfg.run.backend) {
  validate_run_config(cfg_);
  placements_ = place_capsules(cfg_);
  build_state();
  attach_workspace();
}

// Issue 22: the double layer on the single layer's geometry, and the viscosity ratio per capsule.
void Simulation::make_interface_solve() {
  lambda_.assign(placements_.size(), 1.0);
  for (std::size_t k = 0; k < placements_.size(); ++k)
    lambda_[k] = cfg_.species[static_cast<std::size_t>(placements_[k].species)].viscosity_ratio;
  if (cfg_.has_viscosity_contrast()) double_layer_ = std::make_unique<DoubleLayerPlan>(velocity_);
}

Simulation::~Simulation() = default;

Simulation::Simulation(const Config& cfg, const SimulationSnapshot& snap, const std::string& where)
    : cfg_(cfg),
      s_(cfg.capsules.mesh_level, cfg.capsules.membrane),
      velocity_(cfg.domain, cfg.ggem, cfg.run.backend) {
  validate_run_config(cfg_);
  const std::size_t np = snap.species.size();
  if (snap.initial_centres.size() != 3 * np || snap.pinned.size() != np || snap.image.size() != 2 * np ||
      snap.pin_centres.size() != 3 * np)
    throw InputError(where + "inconsistent /state arrays");
  placements_.resize(np);
  for (std::size_t k = 0; k < np; ++k) {
    placements_[k].center = {snap.initial_centres[3 * k], snap.initial_centres[3 * k + 1],
                             snap.initial_centres[3 * k + 2]};
    placements_[k].species = static_cast<int>(snap.species[k]);
    placements_[k].pinned = snap.pinned[k] != 0;
    if (placements_[k].species < 0 || placements_[k].species >= static_cast<int>(cfg_.species.size()))
      throw InputError(where + "capsule species out of range of the stored configuration");
    // Checkpoints of runs without turned capsules store no orientations: every capsule has the identity.
    if (snap.initial_orientations.size() == 9 * np)
      for (std::size_t c = 0; c < 9; ++c) placements_[k].orientation[c] = snap.initial_orientations[9 * k + c];
    else if (!snap.initial_orientations.empty())
      throw InputError(where + "inconsistent /state/initial_orientations");
  }
  build_state();

  const std::size_t n = s_.x.size();
  if (snap.positions.size() != 3 * n || snap.u_previous.size() != 3 * n)
    throw InputError(where + "/state/positions does not match the mesh level and capsule count");
  for (std::size_t i = 0; i < n; ++i) {
    s_.x[i] = snap.positions[3 * i];
    s_.y[i] = snap.positions[3 * i + 1];
    s_.z[i] = snap.positions[3 * i + 2];
    uxp_[i] = snap.u_previous[3 * i];
    uyp_[i] = snap.u_previous[3 * i + 1];
    uzp_[i] = snap.u_previous[3 * i + 2];
  }
  if (snap.have_history2 && snap.u_previous2.size() == 3 * n) {
    for (std::size_t i = 0; i < n; ++i) {
      uxpp_[i] = snap.u_previous2[3 * i];
      uypp_[i] = snap.u_previous2[3 * i + 1];
      uzpp_[i] = snap.u_previous2[3 * i + 2];
    }
    have_history2_ = true;
  }
  image_ = snap.image;
  pin_centre_ = snap.pin_centres;
  time_ = snap.time;
  step_ = snap.step;
  dt_prev_ = snap.dt_previous;
  have_history_ = snap.have_history;
  contact_corrections_ = static_cast<long>(snap.contact_corrections);
  steps_with_contacts_ = static_cast<long>(snap.steps_with_contacts);
  unconverged_contacts_ = static_cast<long>(snap.unconverged_contacts);
  max_ratio_since_record_ = snap.max_step_ratio_since_record;
  // The checkpoint's guess starts the first solve (the uninterrupted run's very guess); the answer before it carries
  // the extrapolation on. Older checkpoints have no previous answer: the next solves start from the last answer.
  gmres_forced_guess_.clear();
  gmres_guess_.clear();
  gmres_prev_answer_.clear();
  if (snap.interface_velocity.size() == 3 * s_.x.size()) gmres_forced_guess_ = snap.interface_velocity;
  if (snap.interface_velocity_previous.size() == 3 * s_.x.size()) {
    gmres_guess_ = snap.interface_velocity_previous;
    gmres_guess_time_ = snap.interface_velocity_previous_time;
  }
  gmres_since_record_.steps = snap.gmres_steps_since_record;
  gmres_since_record_.iterations = snap.gmres_iterations_since_record;
  gmres_since_record_.max_iterations = snap.gmres_max_iterations_since_record;
  gmres_since_record_.max_residual = snap.gmres_max_residual_since_record;
  if (snap.step_limits_since_record.size() == limits_since_record_.size())
    for (std::size_t i = 0; i < limits_since_record_.size(); ++i)
      limits_since_record_[i] = snap.step_limits_since_record[i];
  contact_events_ = static_cast<long>(snap.contact_events);
  attach_workspace();
}

void Simulation::attach_workspace() {
  // Every array of the step at its final size first: the workspace keys arrays by their buffers.
  const std::size_t n = s_.x.size(), nc = static_cast<std::size_t>(s_.num_capsules());
  for (auto* v : {&s_.Fx, &s_.Fy, &s_.Fz, &s_.node_area, &s_.fx, &s_.fy, &s_.fz, &ux_, &uy_, &uz_, &xs_, &ys_, &zs_})
    v->resize(n);
  U_.resize(3 * nc);
  omega_.resize(3 * nc);
  ws_ = std::make_unique<StepWorkspace>(cfg_.run.backend);
  if (!ws_->active()) return;
  node_cells_ = std::make_unique<DeviceNodeCells>(cfg_.run.backend);
  StepWorkspace& w = *ws_;
  w.add(s_.x, "x");
  w.add(s_.y, "y");
  w.add(s_.z, "z");
  w.add(uxp_, "u_previous_x");
  w.add(uyp_, "u_previous_y");
  w.add(uzp_, "u_previous_z");
  w.add(uxpp_, "u_previous2_x");
  w.add(uypp_, "u_previous2_y");
  w.add(uzpp_, "u_previous2_z");
  w.add(ux_, "u_x");
  w.add(uy_, "u_y");
  w.add(uz_, "u_z");
  w.add(xs_, "x_saved");
  w.add(ys_, "y_saved");
  w.add(zs_, "z_saved");
  w.add(s_.Fx, "F_x");
  w.add(s_.Fy, "F_y");
  w.add(s_.Fz, "F_z");
  w.add(s_.node_area, "node_area");
  w.add(s_.fx, "f_x");
  w.add(s_.fy, "f_y");
  w.add(s_.fz, "f_z");
  w.add(wx_, "volume_gradient_x");
  w.add(wy_, "volume_gradient_y");
  w.add(wz_, "volume_gradient_z");
  w.add(U_, "capsule_velocity");
  w.add(omega_, "capsule_rotation");
  // Read-only for the whole run: the mesh, the membrane reference data, per-capsule moduli and target volumes.
  const TriMesh& m = s_.mesh();
  w.add_constant(m.tri, "mesh_tri");
  w.add_constant(m.edges, "mesh_edges");
  w.add_constant(m.inc_offsets, "mesh_inc_offsets");
  w.add_constant(m.inc_tri, "mesh_inc_tri");
  w.add_constant(m.inc_corner, "mesh_inc_corner");
  const MembraneReference ref = s_.reference();
  const std::size_t ne = nc * static_cast<std::size_t>(s_.triangles_per_capsule()) * sizeof(double);
  w.add_range(ref.area0, ne, "reference_area", true);
  w.add_range(ref.g1x, ne, "reference_g1x", true);
  w.add_range(ref.g1y, ne, "reference_g1y", true);
  w.add_range(ref.g2x, ne, "reference_g2x", true);
  w.add_range(ref.g2y, ne, "reference_g2y", true);
  w.add_constant(s_.shear_modulus(), "shear_modulus");
  w.add_constant(s_.membrane_law(), "membrane_law");
  w.add_constant(s_.skalak_c(), "skalak_c");
  w.add_constant(volume0_, "initial_volume");
}

const CapsuleState& Simulation::state() const {
  ws_->host_read(s_.x);
  ws_->host_read(s_.y);
  ws_->host_read(s_.z);
  return s_;
}

void Simulation::build_state() {
  // One CapsuleState species per configured species, in file order (species index = [[species]] index).
  for (std::size_t i = 0; i < cfg_.species.size(); ++i) {
    const SpeciesSpec& sp = cfg_.species[i];
    s_.add_species(SpeciesProperties{state_ca(cfg_, sp.ca), sp.bending_modulus, cfg_.species_membrane(i), sp.shape});
  }
  double ca_min = std::numeric_limits<double>::infinity();
  // The rule's Ca: the smallest over the capsules of Config::species_step_ca, Ca (a_ref / a) g / f with f the law's
  // stiffness factor and g the viscosity ratio's (membrane_parameters.hpp), a_ref the [capsules] radius: the
  // relaxation rate of a grid-scale mode is ~ f Gs / (g mu h), Gs = mu gammadot a / Ca. All three ratios are exactly
  // 1 for neo-Hookean capsules of one size at lambda 1, so such runs keep their steps bit for bit.
  double ca_rule = std::numeric_limits<double>::infinity();
  const std::size_t np = placements_.size();
  pinned_.assign(np, 0);
  pin_centre_.assign(3 * np, 0.0);
  image_.assign(2 * np, 0);
  for (std::size_t k = 0; k < np; ++k) {
    const CapsulePlacement& p = placements_[k];
    const auto sp = static_cast<std::size_t>(p.species);
    const double a = cfg_.species_radius(sp), ca = cfg_.species[sp].ca;
    s_.add_capsule(p.center, a, p.species, p.orientation);
    ca_min = std::min(ca_min, ca);
    ca_rule = std::min(ca_rule, cfg_.species_step_ca(sp));
    pinned_[k] = p.pinned ? 1 : 0;
  }
  ca_step_ = ca_rule;
  for (double k : s_.bending_rigidity()) kappa_max_ = std::max(kappa_max_, k);
  if (cfg_.time.reference_ca) {
    if (*cfg_.time.reference_ca > ca_min)
      throw InputError(cfg_.source + ": [time] reference_ca: expected a number <= the smallest Ca of the capsules (" +
                       num(ca_min) + "), got " + num(*cfg_.time.reference_ca));
    ca_step_ = *cfg_.time.reference_ca * (ca_rule / ca_min);  // the same law and size factors
  }
  // The pinned centre is the centre of mass of the initial (discrete) capsule, not the nominal centre.
  const CapsuleGeometry g = compute_geometry(s_, Backend::Serial);
  for (std::size_t k = 0; k < np; ++k)
    for (int c = 0; c < 3; ++c) pin_centre_[3 * k + c] = g.centroid[3 * k + c];
  volume0_ = g.volume;
  // h_e of the membrane rule: the mean edge of the initial mesh (every capsule has the same one).
  if (np > 0) {
    const std::vector<int>& e = s_.mesh().edges;
    double sum = 0.0;
    for (std::size_t k = 0; k < e.size() / 2; ++k) {
      const std::size_t a = static_cast<std::size_t>(e[2 * k]), b = static_cast<std::size_t>(e[2 * k + 1]);
      sum += std::hypot(s_.x[a] - s_.x[b], s_.y[a] - s_.y[b], s_.z[a] - s_.z[b]);
    }
    h_near_ = sum / static_cast<double>(e.size() / 2);
  }
  const std::size_t n = s_.x.size();
  uxp_.assign(n, 0.0);
  uyp_.assign(n, 0.0);
  uzp_.assign(n, 0.0);
  uxpp_.assign(n, 0.0);
  uypp_.assign(n, 0.0);
  uzpp_.assign(n, 0.0);
  wx_.assign(n, 0.0);
  wy_.assign(n, 0.0);
  wz_.assign(n, 0.0);
  make_interface_solve();
  for (MembraneLaw l : s_.membrane_law()) has_drops_ = has_drops_ || l == MembraneLaw::SurfaceTension;
}

void Simulation::evaluate() {
  if (evaluated_) return;
  const Backend b = cfg_.run.backend;
  StepWorkspace& w = *ws_;
  auto t0 = std::chrono::steady_clock::now();
  for (auto* v : {&s_.x, &s_.y, &s_.z}) w.device_read(*v);
  for (auto* v : {&s_.Fx, &s_.Fy, &s_.Fz, &s_.node_area, &s_.fx, &s_.fy, &s_.fz}) w.device_overwrite(*v);
  s_.compute_membrane_forces(b);
  timings_.forces = seconds_since(t0);
  t0 = std::chrono::steady_clock::now();
  velocity_.set_geometry(s_, ws_.get());
  velocity_.apply(s_, ux_, uy_, uz_);
  add_imposed_flow_x(b, s_.x.size(), imposed_flow_code(cfg_.flow.type), cfg_.flow.shear_rate, cfg_.domain.H,
                     s_.y.data(), ux_.data());
  if (double_layer_) solve_interface_velocity();
  if (has_drops_) normal_motion_of_drops();
  const SingleLayerTimings& vt = velocity_.last_timings();
  timings_.local_nodes = vt.set_geometry + vt.local_nodes;  // the cell list and the pack belong to the local sums
  timings_.local_walls = vt.local_walls;
  timings_.global = vt.global;
  timings_.velocity_total = seconds_since(t0);
  if (cfg_.capsules.velocity_projection) project_velocities();
  for (auto* v : {&ux_, &uy_, &uz_}) w.device_read(*v);
  w.device_overwrite(U_);
  w.device_overwrite(omega_);
  compute_mean_velocity(s_, b, ux_, uy_, uz_, U_, omega_);
  evaluated_ = true;
}

void Simulation::solve_interface_velocity() {
  const auto t0 = std::chrono::steady_clock::now();
  // GMRES is host code: on the device backend the positions are read on both sides (the double layer's kernels find
  // them resident, its host parts read them here) and the velocity comes to the host, to go back after the solve.
  for (const auto* v : {&s_.x, &s_.y, &s_.z}) ws_->host_read(*v);
  for (auto* v : {&ux_, &uy_, &uz_}) ws_->host_write(*v);
  double_layer_->set_geometry();
  const std::size_t n = s_.x.size();
  const int nv = s_.nodes_per_capsule();
  gmres_b_.resize(3 * n);
  gmres_x_.resize(3 * n);
  for (int c = 0; c < 3; ++c) {
    dl_q_[c].resize(n);
    dl_k_[c].resize(n);
  }
  const std::vector<double>* u[3] = {&ux_, &uy_, &uz_};
  for (int c = 0; c < 3; ++c)
    for (std::size_t i = 0; i < n; ++i) gmres_b_[c * n + i] = (*u[c])[i];
  // First guess: the last two answers extrapolated to this strain (the checkpoint keeps what a restart needs to repeat
  // the solve bit for bit); the first solve of a run starts from the right-hand side.
  const bool had_guess = gmres_first_guess(time_, gmres_x_);
  if (!had_guess) gmres_x_ = gmres_b_;
  // A u = ((1 + lambda)/2) u - K~[(1 - lambda) u], lambda of each node's capsule.
  auto apply = [&](const double* in, double* out) {
    for (int c = 0; c < 3; ++c)
      for (std::size_t i = 0; i < n; ++i) dl_q_[c][i] = (1.0 - lambda_[i / nv]) * in[c * n + i];
    double_layer_->apply(NodeField{dl_q_[0], dl_q_[1], dl_q_[2]}, NodeFieldOut{dl_k_[0], dl_k_[1], dl_k_[2]});
    for (int c = 0; c < 3; ++c)
      for (std::size_t i = 0; i < n; ++i) out[c * n + i] = 0.5 * (1.0 + lambda_[i / nv]) * in[c * n + i] - dl_k_[c][i];
  };
  GmresOptions opt;
  opt.tolerance = cfg_.gmres.tolerance;
  opt.restart = cfg_.gmres.restart;
  opt.max_iterations = cfg_.gmres.max_iterations;
  // The guess this solve starts from (a snapshot taken before the step stores it: the restored run then repeats
  // this very solve), then the answer, the next solve's guess.
  // Empty for the right-hand side (the first solve): a checkpoint then stores no guess, as at step 0.
  if (had_guess)
    gmres_used_guess_ = gmres_x_;
  else
    gmres_used_guess_.clear();
  gmres_last_ = gmres(3 * n, apply, gmres_b_.data(), gmres_x_.data(), opt);
  gmres_forced_guess_.clear();
  gmres_prev_answer_.swap(gmres_guess_);
  gmres_prev_answer_time_ = gmres_guess_time_;
  gmres_guess_ = gmres_x_;
  gmres_guess_time_ = time_;
  std::vector<double>* uo[3] = {&ux_, &uy_, &uz_};
  for (int c = 0; c < 3; ++c)
    for (std::size_t i = 0; i < n; ++i) (*uo[c])[i] = gmres_x_[c * n + i];
  timings_.interface_solve = seconds_since(t0);
}

// The first guess of the interface solve at strain t: a restored checkpoint's own; else the last answer u1 (strain
// t1) extrapolated linearly with the one before, u2 (t2): u1 + (t - t1)/(t1 - t2) (u1 - u2). The answer moves
// smoothly with the suspension, so the extrapolation leaves an initial residual of O(dt^2) instead of O(dt): fewer
// GMRES iterations for the same tolerance (issue 34, docs/performance.md).
bool Simulation::gmres_first_guess(double t, std::vector<double>& x) const {
  const std::size_t m = 3 * s_.x.size();
  if (gmres_forced_guess_.size() == m) {
    x = gmres_forced_guess_;
    return true;
  }
  if (gmres_guess_.size() != m) return false;
  x.resize(m);
  const double t1 = gmres_guess_time_, t2 = gmres_prev_answer_time_;
  if (gmres_prev_answer_.size() != m || !(t1 > t2) || !(t > t1)) {
    std::copy(gmres_guess_.begin(), gmres_guess_.end(), x.begin());
    return true;
  }
  const double r = (t - t1) / (t1 - t2);
  for (std::size_t i = 0; i < m; ++i) x[i] = gmres_guess_[i] + r * (gmres_guess_[i] - gmres_prev_answer_[i]);
  return true;
}

// A drop (law = "surface-tension") is only its shape: its nodes move with the normal component (u.n) n, so the mesh
// does not drift with the tangential flow (it has no in-plane stiffness to hold it). Area-weighted node normals.
void Simulation::normal_motion_of_drops() {
  for (const auto* v : {&s_.x, &s_.y, &s_.z}) ws_->host_read(*v);
  for (auto* v : {&ux_, &uy_, &uz_}) ws_->host_write(*v);
  for (auto* v : {&wx_, &wy_, &wz_}) ws_->host_overwrite(*v);
  compute_node_normals(s_, Backend::Serial, wx_, wy_, wz_);
  const int nv = s_.nodes_per_capsule();
  const auto& law = s_.membrane_law();
  for (int k = 0; k < s_.num_capsules(); ++k) {
    if (law[static_cast<std::size_t>(k)] != MembraneLaw::SurfaceTension) continue;
    for (std::size_t i = static_cast<std::size_t>(k) * nv; i < static_cast<std::size_t>(k + 1) * nv; ++i) {
      const double un = ux_[i] * wx_[i] + uy_[i] * wy_[i] + uz_[i] * wz_[i];
      ux_[i] = un * wx_[i];
      uy_[i] = un * wy_[i];
      uz_[i] = un * wz_[i];
    }
  }
}

void Simulation::project_velocities() {
  const Backend b = cfg_.run.backend;
  for (auto* v : {&wx_, &wy_, &wz_}) ws_->device_overwrite(*v);
  for (auto* v : {&ux_, &uy_, &uz_}) ws_->device_write(*v);
  const TriMesh& m = s_.mesh();
  volume_gradient(b, s_.num_capsules(), s_.nodes_per_capsule(), m.tri.data(), m.inc_offsets.data(),
                  m.inc_tri.data(), s_.x.data(), s_.y.data(), s_.z.data(), wx_.data(), wy_.data(), wz_.data());
  project_volume_rate(b, s_.num_capsules(), s_.nodes_per_capsule(), wx_.data(), wy_.data(), wz_.data(), ux_.data(),
                      uy_.data(), uz_.data());
}

double Simulation::min_node_distance(bool* between) const {
  const CapsuleGeometry& g = current_geometry(geometry_backend());
  double h = g.global_min_edge;
  // Node pairs of different capsules closer than h, from one node cell list (cells >= h): O(nodes), where a search
  // per candidate capsule pair cost O(pairs nv^2). On the device backend the list is binned and searched on the
  // device over the resident positions (kernels/device_cells: one scalar comes back), elsewhere on the host
  // (kernels/slit_cells); the minimum is exact in any order, so every backend gets the same h.
  double hp;
  if (node_cells_) {
    for (const auto* v : {&s_.x, &s_.y, &s_.z}) ws_->device_read(*v);
    node_cells_->build(cfg_.domain.Lx, cfg_.domain.H, cfg_.domain.Lz, h, s_.x.size(), s_.x.data(), s_.y.data(),
                       s_.z.data());
    ws_->note_scalar_results(1);
    hp = node_cells_->min_node_distance_between_capsules(s_.nodes_per_capsule(), s_.x.data(), s_.y.data(),
                                                         s_.z.data(), h);
  } else {
    SlitCells cells;
    bin_points(cells, cfg_.domain.Lx, cfg_.domain.H, cfg_.domain.Lz, h, s_.x.size(), s_.x.data(), s_.y.data(),
               s_.z.data());
    hp = min_node_distance_between_capsules(cfg_.run.backend, cells, s_.nodes_per_capsule(), s_.x.data(),
                                            s_.y.data(), s_.z.data(), h);
  }
  const bool from_pair = hp < h;
  if (from_pair) h = hp;
  if (between) *between = from_pair;
  return h;
}

ClosingLimits Simulation::closing_limits() const {
  return closing_limits_at(current_geometry(geometry_backend()).centroid);
}

const CapsuleGeometry& Simulation::current_geometry(Backend b) const {
  if (!geometry_cached_ || geometry_cache_backend_ != b) {
    // The device geometry reads the resident positions; the serial one the host copy (pulled once).
    geometry_cache_ = compute_geometry(b == Backend::Device ? s_ : state(), b);
    geometry_cache_backend_ = b;
    geometry_cached_ = true;
  }
  return geometry_cache_;
}

void Simulation::positions_changed() {
  evaluated_ = false;
  geometry_cached_ = false;
  closing_cached_ = false;
}

// Always at the current geometry's centroids (the two callers pass them), so one cached value per positions and
// velocities serves the step rule and the record's diagnostics.
ClosingLimits Simulation::closing_limits_at(const std::vector<double>& centroid) const {
  if (closing_cached_ && evaluated_) return closing_cache_;
  for (const auto* v : {&s_.x, &s_.y, &s_.z, &ux_, &uy_, &uz_}) ws_->device_read(*v);
  ws_->note_scalar_results(1);
  closing_cache_ = capsflow::closing_limits(s_, centroid, ux_.data(), uy_.data(), uz_.data(), cfg_.domain.Lx,
                                            cfg_.domain.Lz, cfg_.domain.H, h_near_, cfg_.time.min_gap,
                                            cfg_.run.backend);
  closing_cached_ = evaluated_;
  return closing_cache_;
}

double Simulation::ab2_error_proxy() const {
  if (!have_history2_ || !evaluated_) return std::numeric_limits<double>::quiet_NaN();
  for (const auto* v : {&ux_, &uy_, &uz_, &uxp_, &uyp_, &uzp_, &uxpp_, &uypp_, &uzpp_}) ws_->device_read(*v);
  ws_->note_scalar_results(1);
  const double d2 = max_second_difference(cfg_.run.backend, s_.x.size(), ux_.data(), uy_.data(), uz_.data(),
                                          uxp_.data(), uyp_.data(), uzp_.data(), uxpp_.data(), uypp_.data(),
                                          uzpp_.data());
  return 5.0 / 12.0 * (dt_prev_ / cfg_.flow.shear_rate) * d2;
}

double Simulation::bending_step(double h) const {
  if (!(kappa_max_ > 0.0)) return std::numeric_limits<double>::infinity();
  return cfg_.time.bending_cfl * cfg_.domain.viscosity * cfg_.flow.shear_rate * h * h * h / kappa_max_;
}

double Simulation::bending_step(const CapsuleGeometry& g) const {
  // Per capsule: its own shortest edge and rigidity, so small stiff-free capsules (platelets without bending) or
  // fine meshes of other species do not set the bending limit of the red cells.
  double dt = std::numeric_limits<double>::infinity();
  const std::vector<double>& kappa = s_.bending_rigidity();
  for (std::size_t k = 0; k < kappa.size(); ++k) {
    if (!(kappa[k] > 0.0)) continue;
    const double h = g.min_edge[k];
    dt = std::min(dt, cfg_.time.bending_cfl * cfg_.domain.viscosity * cfg_.flow.shear_rate * h * h * h / kappa[k]);
  }
  return dt;
}

double Simulation::with_bending(double dt_elastic, const CapsuleGeometry& g) const {
  return 1.0 / (1.0 / dt_elastic + 1.0 / bending_step(g));
}

double Simulation::with_bending(double dt_elastic, double h) const {
  // Bending relaxes a mode of wavenumber k at a rate ~ kappa k^3 / mu, the in-plane elasticity at ~ Gs k / mu, and
  // the grid-scale modes feel both: the rates add, so the limits combine harmonically (the probe: docs/method.md
  // section 4.1). Called only with bending, so runs without it keep their bits.
  return 1.0 / (1.0 / dt_elastic + 1.0 / bending_step(h));
}

void Simulation::choose_step(StepInfo& info) {
  const double ca = ca_step_;
  if (cfg_.time.step_rule == StepRule::Paper) {
    info.h = min_node_distance(&info.h_between_capsules);
    info.dt = cfg_.rule_step(ca, info.h);  // D8, strain units
    info.limit = info.h_between_capsules ? StepLimit::PaperGap : StepLimit::Membrane;
    if (kappa_max_ > 0.0) info.dt = with_bending(info.dt, current_geometry(geometry_backend()));
  } else {
    // The explicit step's stability limit scales with Ca times the element size; a gap is a transport question,
    // answered by the collision cap (docs/method.md section 4.1, with the stability probe's table).
    const CapsuleGeometry& g = current_geometry(geometry_backend());
    info.h = g.global_min_edge;
    info.dt_membrane = cfg_.rule_step(ca, info.h);
    if (kappa_max_ > 0.0) info.dt_membrane = with_bending(info.dt_membrane, g);
    const ClosingLimits cl = closing_limits_at(g.centroid);
    info.pair_gap = cl.pair_gap;
    // Velocities are per unit time; time_to_close in physical time, dt in strain units.
    info.dt_collision = cfg_.time.c_gap * cl.time_to_close * cfg_.flow.shear_rate;
    info.dt = info.dt_membrane;
    info.limit = StepLimit::Membrane;
    if (cl.pair_gap < h_near_ && cfg_.time.near_contact_factor < 1.0) {
      info.dt *= cfg_.time.near_contact_factor;
      info.limit = StepLimit::NearContact;
    }
    if (info.dt_collision < info.dt) {
      info.dt = info.dt_collision;
      info.limit = StepLimit::Collision;
    }
  }
  if (have_history_) {
    // The AB2 weights extrapolate by r/2: a pair separating can raise h tenfold in one step (D8's cap).
    const double cap = cfg_.time.max_step_ratio * dt_prev_;
    if (info.dt > cap) {
      info.dt = cap;
      info.capped = true;
      info.limit = StepLimit::Ratio;
    }
    info.ratio = info.dt / dt_prev_;
  }
}

StepInfo Simulation::advance() {
  StepInfo info = plan_step();
  if (info.stop != StopReason::None) return info;
  return take_step(std::move(info));
}

StepInfo Simulation::advance(StepInfo planned) {
  if (planned.stop != StopReason::None) throw std::logic_error("Simulation::advance: the planned step was stopped");
  return take_step(std::move(planned));
}

StepInfo Simulation::plan_step() {
  evaluate();
  StepInfo info;
  const std::size_t n = s_.x.size();
  ws_->note_scalar_results(1);
  // A solve from finite data that did not converge is the solve's failure (the velocities are its unconverged answer);
  // with non-finite data (forces, a NaN imposed velocity) it is the data's.
  if (double_layer_ && !gmres_last_.converged && all_finite(gmres_b_)) {
    info.stop = StopReason::SolveNotConverged;
    info.message = gmres_failure(cfg_, gmres_last_) + " at strain " + num(time_) + " (step " +
                   std::to_string(step_) + ")" +
                   (std::isfinite(gmres_last_.residual)
                        ? "; continue with a larger cap: capsflow run --restart CHECKPOINT --set gmres.max_iterations=N "
                          "(or a larger [gmres] restart)"
                        : "");
    return info;
  }
  if (!all_finite3(cfg_.run.backend, n, ux_.data(), uy_.data(), uz_.data())) {
    info.stop = StopReason::NotFinite;
    info.message = "a node velocity is not finite at strain " + num(time_) + " (step " +
                   std::to_string(step_) + ")";
    return info;
  }
  const auto t0 = std::chrono::steady_clock::now();
  choose_step(info);
  timings_.step_size = seconds_since(t0);
  if (!(info.dt >= cfg_.time.dt_floor)) {
    info.stop = StopReason::DtBelowFloor;
    info.message = "the time step " + num(info.dt) + " fell below [time] dt_floor = " + num(cfg_.time.dt_floor) +
                   " (set by " +
                   (step_limit_keys(cfg_, info, h_near_).empty()
                        ? std::string(step_limit_name(info.limit)) + ", h = " + num(info.h) +
                              (info.h_between_capsules ? " between two capsules" : " inside a capsule")
                        : step_limit_keys(cfg_, info, h_near_)) +
                   ") at strain " + num(time_);
  }
  return info;
}

std::string Simulation::next_step_problem() {
  const std::size_t n = s_.x.size();
  const Backend be = cfg_.run.backend;
  ws_->note_scalar_results(1);
  if (!all_finite3(be, n, s_.x.data(), s_.y.data(), s_.z.data())) return "a node position is not finite";
  evaluate();
  if (double_layer_ && !gmres_last_.converged && all_finite(gmres_b_))
    return gmres_failure(cfg_, gmres_last_) + " at strain " + num(time_) +
           (std::isfinite(gmres_last_.residual)
                ? "; expected more operator applications (max_iterations, restart) or a looser tolerance"
                : "");
  ws_->note_scalar_results(1);
  if (!all_finite3(be, n, ux_.data(), uy_.data(), uz_.data()))
    return "the membrane forces give a non-finite node velocity at strain " + num(time_) +
           "; expected finite forces from " + membrane_keys(cfg_);
  StepInfo info;
  choose_step(info);
  // The species whose Ca sets Ca_ref (the smallest Config::species_step_ca over the capsules), to name its keys.
  std::size_t ca_species = static_cast<std::size_t>(placements_.empty() ? 0 : placements_[0].species);
  for (const CapsulePlacement& p : placements_)
    if (cfg_.species_step_ca(static_cast<std::size_t>(p.species)) < cfg_.species_step_ca(ca_species))
      ca_species = static_cast<std::size_t>(p.species);
  std::string set_by = "[time] cfl = " + num(cfg_.time.cfl) + " x Ca_ref = " + num(ca_step_) +
                       " (" + step_ca_keys(cfg_, ca_species) + ") x h / a_ref = " + num(info.h / cfg_.capsules.radius) +
                       " (the shortest edge h = " + num(info.h) + " from the radii and [capsules] mesh_level, a_ref the "
                       "[capsules] radius)";
  if (kappa_max_ > 0.0)
    set_by += ", combined with the bending limit [time] bending_cfl = " + num(cfg_.time.bending_cfl) +
              " x mu min_k(h_k^3 / kappa_k) over the capsules with bending, kappa up to " + num(kappa_max_) +
              " (from [[species]] bending_modulus)";
  // A step held below the membrane rule is named by the key that held it, not by the rule's (issue 37: a tiny c_gap
  // or near_contact_factor was reported as "[time] cfl = 0.5 x ...").
  const std::string held = step_limit_keys(cfg_, info, h_near_);
  if (!held.empty()) set_by = held + ", below the membrane rule's " + num(info.dt_membrane) + " = " + set_by;
  if (!std::isfinite(info.dt) || !(info.dt >= cfg_.time.dt_floor))
    return "the time step " + num(info.dt) + " = " + set_by + " is " +
           (std::isfinite(info.dt) ? "below [time] dt_floor = " + num(cfg_.time.dt_floor) : std::string("not finite")) +
           "; expected a step of at least dt_floor";
  // The step moves node i by dt (a u^n + b u^(n-1)) / gammadot (AB2; Euler on the first step).
  double a = 1.0, b = 0.0;
  if (have_history_) {
    const double r = info.dt / dt_prev_;
    a = 1.0 + 0.5 * r;
    b = -0.5 * r;
  }
  for (auto* v : {&ux_, &uy_, &uz_, &uxp_, &uyp_, &uzp_}) ws_->host_read(*v);
  double move = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double dx = a * ux_[i] + b * uxp_[i], dy = a * uy_[i] + b * uyp_[i], dz = a * uz_[i] + b * uzp_[i];
    move = std::max(move, std::sqrt(dx * dx + dy * dy + dz * dz));
  }
  move *= info.dt / cfg_.flow.shear_rate;
  if (!(move <= cfg_.domain.H))
    return "the time step " + num(info.dt) + " = " + set_by + " would move a node by " + num(move) +
           ", more than the slit height H = " + num(cfg_.domain.H) + "; expected a step that moves nodes by a "
           "fraction of an element (check [time] cfl, [time] reference_ca, [[species]] ca and [capsules] inflation)";
  return "";
}

StepInfo Simulation::advance_fixed(double dt) {
  evaluate();
  StepInfo info;
  info.dt = dt;
  if (have_history_) info.ratio = dt / dt_prev_;
  return take_step(std::move(info));
}

StepInfo Simulation::take_step(StepInfo info) {
  const std::size_t n = s_.x.size();
  const Backend be = cfg_.run.backend, gb = geometry_backend();
  StepWorkspace& w = *ws_;
  auto t0 = std::chrono::steady_clock::now();
  for (auto* v : {&xs_, &ys_, &zs_}) w.device_overwrite(*v);
  copy3(be, n, s_.x.data(), s_.y.data(), s_.z.data(), xs_.data(), ys_.data(), zs_.data());
  // The geometry and gap caches belong to x^n; evaluated_ stays until the step is kept (a stopped step restores x^n
  // and keeps u^n).
  geometry_cached_ = false;
  closing_cached_ = false;
  // Variable-step AB2 (method-spec 8.1); physical time step dt / gammadot.
  const double dtp = info.dt / cfg_.flow.shear_rate;
  double a = 1.0, b = 0.0;
  if (have_history_) {
    const double r = info.dt / dt_prev_;
    a = 1.0 + 0.5 * r;
    b = -0.5 * r;
  }
  for (auto* v : {&uxp_, &uyp_, &uzp_}) w.device_read(*v);
  for (auto* v : {&s_.x, &s_.y, &s_.z}) w.device_write(*v);
  ab2_update(be, n, dtp, a, b, ux_.data(), uy_.data(), uz_.data(), uxp_.data(), uyp_.data(), uzp_.data(), s_.x.data(),
             s_.y.data(), s_.z.data());
  timings_.update = seconds_since(t0);

  // Order (D11 revised): position projection before contact, so the contact control has the last word on gaps.
  if (cfg_.capsules.volume_correction) correct_volumes();
  t0 = std::chrono::steady_clock::now();
  info.contact = resolve_contacts(s_, cfg_.domain.Lx, cfg_.domain.Lz, cfg_.domain.H, cfg_.time.min_gap,
                                  cfg_.run.backend);
  timings_.contact = seconds_since(t0);
  pin_and_wrap();

  // Check before keeping: a bad step leaves x^n in place for the final checkpoint. Reductions on the device: only
  // their scalars come back (and y when a node has left, for the message).
  StopReason bad = StopReason::None;
  std::string why;
  w.note_scalar_results(1);
  if (!all_finite3(be, n, s_.x.data(), s_.y.data(), s_.z.data())) {
    bad = StopReason::NotFinite;
    why = "a node position became non-finite";
  } else {
    const double H = cfg_.domain.H;
    w.note_scalar_results(1);
    const long i = first_outside(be, n, s_.y.data(), 0.0, H);
    if (i >= 0) {
      w.host_read(s_.y);
      bad = StopReason::LeftSlit;
      why = "capsule " + std::to_string(static_cast<std::size_t>(i) / static_cast<std::size_t>(s_.nodes_per_capsule())) +
            " left the slit (node at y = " + num(s_.y[static_cast<std::size_t>(i)]) + ", walls at 0 and " + num(H) +
            "; contact control " + (info.contact.converged ? "converged" : "did not converge") + ")";
    }
  }
  if (bad == StopReason::None) {
    w.note_scalar_results(1);
    const double re = max_element_radius(gb, s_.num_capsules(), s_.nodes_per_capsule(), s_.triangles_per_capsule(),
                                         s_.mesh().tri.data(), s_.x.data(), s_.y.data(), s_.z.data());
    const double cutoff = velocity_.grid().cutoff;
    if (!(2.0 * (cutoff + re) < std::min(cfg_.domain.Lx, cfg_.domain.Lz))) {
      bad = StopReason::MeshTooLarge;
      why = "a membrane element grew to radius " + num(re) +
            " (the local sums need Lx, Lz > 2 (cutoff + element radius); the mesh is blowing up or the box is too "
            "small)";
    }
  }
  if (bad == StopReason::None && !info.contact.converged) {
    // A contact control that leaves overlaps would let the next step start from them (T5 of the step-rule issue).
    bad = StopReason::ContactFailed;
    why = "the contact control did not reach min_gap = " + num(cfg_.time.min_gap) + " (smallest gap " +
          num(info.contact.final_min_gap) + " after " + std::to_string(info.contact.iterations) + " iterations)";
  }
  if (bad != StopReason::None) {
    w.swap(s_.x, xs_);
    w.swap(s_.y, ys_);
    w.swap(s_.z, zs_);
    info.stop = bad;
    info.message = why + " in the step from strain " + num(time_) + " (step " + std::to_string(step_) +
                   ", dt " + num(info.dt) + ")";
    return info;
  }

  const long corr = info.contact.pair_corrections + info.contact.wall_corrections;
  contact_corrections_ += corr;
  if (corr > 0) ++steps_with_contacts_;
  if (!info.contact.converged) ++unconverged_contacts_;
  // History: u^{n-2} <- u^{n-1} <- u^n (ux_ then holds stale values until the next evaluate()).
  w.swap(uxpp_, uxp_);
  w.swap(uypp_, uyp_);
  w.swap(uzpp_, uzp_);
  w.swap(uxp_, ux_);
  w.swap(uyp_, uy_);
  w.swap(uzp_, uz_);
  have_history2_ = have_history_;
  have_history_ = true;
  max_ratio_since_record_ = std::max(max_ratio_since_record_, info.ratio);
  ++limits_since_record_[static_cast<std::size_t>(info.limit)];
  // The solve at x^n counts with the step it served, not when it ran: a checkpoint of an evaluated state leaves it
  // out, and the continued run, which solves x^n again, counts it once (restarts keep the GMRES record's bits).
  if (double_layer_) {
    GmresRecordStats& st = gmres_since_record_;
    ++st.steps;
    st.iterations += gmres_last_.iterations;
    st.max_iterations = std::max<std::int64_t>(st.max_iterations, gmres_last_.iterations);
    st.max_residual = std::max(st.max_residual, gmres_last_.residual);
  }
  dt_prev_ = info.dt;
  time_ += info.dt;
  for (const ContactEvent& e : info.contact.events) {
    events_.push_back({time_, e.p, e.wall >= 0 ? -(e.wall + 1) : e.q, e.gap_before, e.dy_p, e.dy_q});
    ++contact_events_;
  }
  ++step_;
  positions_changed();
  return info;
}

void Simulation::pin_and_wrap() {
  const int nc = s_.num_capsules(), nv = s_.nodes_per_capsule();
  const Backend gb = geometry_backend();
  // Per-capsule decisions on the host (3 doubles a capsule come back), node updates as kernels.
  std::vector<double> off(3 * static_cast<std::size_t>(nc), 0.0);
  bool any_pinned = false, any = false;
  for (char p : pinned_) any_pinned = any_pinned || p;
  if (any_pinned) {
    // D10: translate a pinned capsule so that its centre of mass is back where it started.
    const CapsuleGeometry g = compute_geometry(s_, gb);
    for (int k = 0; k < nc; ++k) {
      if (!pinned_[k]) continue;
      for (int c = 0; c < 3; ++c) off[3 * k + c] = pin_centre_[3 * k + c] - g.centroid[3 * k + c];
    }
    translate_capsules(gb, nc, nv, off.data(), s_.x.data(), s_.y.data(), s_.z.data());
  }
  // Keep every capsule's node mean inside the periodic box, so positions stay O(L) on long runs.
  const double L[2] = {cfg_.domain.Lx, cfg_.domain.Lz};
  std::vector<double> mean(3 * static_cast<std::size_t>(nc));
  capsule_node_means(gb, nc, nv, s_.x.data(), s_.y.data(), s_.z.data(), mean.data());
  for (int k = 0; k < nc; ++k)
    for (int d = 0; d < 2; ++d) {
      const int c = 2 * d;  // x or z
      const double shift = std::floor(mean[3 * k + c] / L[d]);
      off[3 * k + c] = -(shift * L[d]);  // x + -(s L) is x - s L exactly
      off[3 * k + 1] = 0.0;
      if (shift == 0.0) continue;
      image_[2 * k + d] += static_cast<std::int64_t>(shift);
      any = true;
    }
  if (any) translate_capsules(gb, nc, nv, off.data(), s_.x.data(), s_.y.data(), s_.z.data());
}

void Simulation::correct_volumes() {
  // Newton on V(delta) for a displacement delta along the node normals n_i = w_i / |w_i|, w_i = dV/dx_i:
  // dV/d(delta) = sum_i |w_i| exactly (using the area A instead leaves a mesh-dependent fraction of the deficit,
  // 15 % at level 1). Two iterations leave O(deficit^3).
  const int nc = s_.num_capsules(), nv = s_.nodes_per_capsule();
  const Backend gb = geometry_backend();
  const TriMesh& m = s_.mesh();
  for (auto* v : {&wx_, &wy_, &wz_}) ws_->device_overwrite(*v);
  for (int it = 0; it < 2; ++it) {
    const CapsuleGeometry g = compute_geometry(s_, gb);
    volume_gradient(gb, nc, nv, m.tri.data(), m.inc_offsets.data(), m.inc_tri.data(), s_.x.data(), s_.y.data(),
                    s_.z.data(), wx_.data(), wy_.data(), wz_.data());
    volume_correction_step(gb, nc, nv, volume0_.data(), g.volume.data(), wx_.data(), wy_.data(), wz_.data(),
                           s_.x.data(), s_.y.data(), s_.z.data());
  }
}

FlowDiagnostics flow_diagnostics(const CapsuleState& s, const Config& cfg, const std::vector<double>& interface_velocity,
                                 const std::vector<double>& lambda) {
  // Plane-averaged (k = 0) disturbance of a force F_x at height h between fixed walls (validation-data 5):
  // u'(y) = F_x/(mu A) y (H - h)/H below, F_x/(mu A) h (H - y)/H above. Its flux is F_x h (H - h) / (2 mu A) and
  // the wall shear stress it adds is -F_x h / (A H) (force-free capsules: sum F_x = 0). The density f is linear
  // on each flat element, as the single layer integrates it: int_T f g dA with g = y or y (H - y) is exact with
  // int lambda_i lambda_j lambda_k dA = 2A i!j!k!-multiplicities / 5! (A/10, A/30, A/60).
  FlowDiagnostics d;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  d.flow_rate_ratio = nan;
  d.relative_viscosity = nan;
  if (cfg.flow.type == FlowType::None) return d;
  const double H = cfg.domain.H, A = cfg.domain.Lx * cfg.domain.Lz, mu = cfg.domain.viscosity;
  const double gd = cfg.flow.shear_rate;
  const int nc = s.num_capsules(), nv = s.nodes_per_capsule(), nt = s.triangles_per_capsule();
  const int* tri = s.mesh().tri.data();
  double m1 = 0.0, m2 = 0.0;  // sum int f_x y dA, sum int f_x y (H - y) dA
  const std::size_t n = s.x.size();
  for (int k = 0; k < nc; ++k) {
    const std::size_t o = static_cast<std::size_t>(k) * nv;
    const double dl = lambda.empty() ? 0.0 : 1.0 - lambda[static_cast<std::size_t>(k)];
    const bool double_layer = dl != 0.0 && interface_velocity.size() == 3 * n;
    // The node mean p: the interior's flux below is taken about it (translation-invariant when the discrete
    // oint u.n is not exactly zero, as the capsule velocity U of capsule_velocity_moments).
    double px = 0.0;
    if (double_layer) {
      for (int i = 0; i < nv; ++i) px += s.x[o + static_cast<std::size_t>(i)];
      px /= nv;
    }
    double inner = 0.0;  // int_V u_x dV = oint (x - p_x)(u.n) dS of this capsule
    for (int e = 0; e < nt; ++e) {
      const std::size_t v[3] = {o + tri[3 * e], o + tri[3 * e + 1], o + tri[3 * e + 2]};
      const double ax = s.x[v[1]] - s.x[v[0]], ay = s.y[v[1]] - s.y[v[0]], az = s.z[v[1]] - s.z[v[0]];
      const double bx = s.x[v[2]] - s.x[v[0]], by = s.y[v[2]] - s.y[v[0]], bz = s.z[v[2]] - s.z[v[0]];
      const double cx = ay * bz - az * by, cy = az * bx - ax * bz, cz = ax * by - ay * bx;
      const double area = 0.5 * std::sqrt(cx * cx + cy * cy + cz * cz);
      const double f[3] = {s.fx[v[0]], s.fx[v[1]], s.fx[v[2]]};
      const double y[3] = {s.y[v[0]], s.y[v[1]], s.y[v[2]]};
      double fy = 0.0, fyy = 0.0;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
          fy += f[i] * y[j] * (i == j ? area / 6.0 : area / 12.0);
          for (int l = 0; l < 3; ++l) {
            const double w = (i == j && j == l) ? area / 10.0 : (i != j && j != l && i != l) ? area / 60.0
                                                                                               : area / 30.0;
            fyy += f[i] * y[j] * y[l] * w;
          }
        }
      m1 += fy;
      m2 += H * fy - fyy;
      // The double layer of (1 - lambda) u is a force dipole mu (1 - lambda) (u n + n u) dS per element (plus mass
      // sources, which drive no plane-averaged x flow; docs/method.md 3.1, 4.5). A dipole D_xy at height h adds D_xy
      // to M_1 and D_xy (H - 2 h) to M_2 (the limit of two opposite forces); u linear on the element, n constant:
      // D_xy = mu (1 - lambda) (n_y int u_x + n_x int u_y), and int u y dA by the same exact weights as above.
      if (double_layer) {
        const double nx = cx / (2.0 * area), ny = cy / (2.0 * area), nz = cz / (2.0 * area);
        double q0 = 0.0, q1 = 0.0;  // int (n_y u_x + n_x u_y) dA and int (n_y u_x + n_x u_y) y dA
        for (int i = 0; i < 3; ++i) {
          const double ux = interface_velocity[v[i]], uy = interface_velocity[n + v[i]];
          const double qi = ny * ux + nx * uy;
          const double un = nx * ux + ny * uy + nz * interface_velocity[2 * n + v[i]];
          q0 += qi * area / 3.0;
          for (int j = 0; j < 3; ++j) {
            const double w = i == j ? area / 6.0 : area / 12.0;
            q1 += qi * y[j] * w;
            inner += un * (s.x[v[j]] - px) * w;
          }
        }
        m1 += mu * dl * q0;
        m2 += mu * dl * (H * q0 - 2.0 * q1);
      }
    }
    // The representation u_inf + S[f] + (1 - lambda) K[u] is u outside a capsule but lambda u inside it (the
    // interface equation is its limit on the surface, (1 + lambda)/2 u), and the moments above give the flux of that
    // field. A cross-section's flux counts the inner fluid's velocity with weight 1: add (1 - lambda) int_V u_x dV / A
    // to Q, i.e. 2 mu (1 - lambda) int_V u_x dV to M_2 (docs/method.md 4.5). The walls lie outside every capsule, so
    // the wall stress (M_1) needs nothing.
    if (double_layer) m2 += 2.0 * mu * dl * inner;
  }
  if (cfg.flow.type == FlowType::Poiseuille) d.flow_rate_ratio = 1.0 + 3.0 * m2 / (mu * A * gd * H * H);
  if (cfg.flow.type == FlowType::Shear) d.relative_viscosity = 1.0 - m1 / (mu * gd * A * H);
  return d;
}

FlowDiagnostics Simulation::flow_diagnostics() const {
  for (const auto* v : {&s_.x, &s_.y, &s_.z, &s_.fx}) ws_->host_read(*v);
  // The interface velocity of these positions: the last solve's whole answer (the node velocities may have lost
  // their tangential part, drops, or been projected).
  if (double_layer_ && evaluated_) return capsflow::flow_diagnostics(s_, cfg_, gmres_guess_, lambda_);
  return capsflow::flow_diagnostics(s_, cfg_);
}

std::vector<double> Simulation::species_profile(int bins) const {
  state();  // host-valid positions
  const int nc = s_.num_capsules(), nv = s_.nodes_per_capsule(), nt = s_.triangles_per_capsule();
  const std::size_t nb = static_cast<std::size_t>(bins);
  std::vector<double> out(cfg_.species.size() * nb, 0.0);
  for (int k = 0; k < nc; ++k) {
    const std::size_t o = static_cast<std::size_t>(k) * nv;
    double* row = out.data() + static_cast<std::size_t>(s_.species_of(k)) * nb;
    capsule_slab_volumes(nv, nt, s_.mesh().tri.data(), &s_.x[o], &s_.y[o], &s_.z[o], cfg_.domain.H, bins, row);
  }
  return out;
}

CapsuleGeometry Simulation::geometry() const { return current_geometry(Backend::Serial); }

std::vector<double> Simulation::unwrapped_centroids(const CapsuleGeometry& g) const {
  std::vector<double> c = g.centroid;
  for (std::size_t k = 0; k < image_.size() / 2; ++k) {
    c[3 * k] += static_cast<double>(image_[2 * k]) * cfg_.domain.Lx;
    c[3 * k + 2] += static_cast<double>(image_[2 * k + 1]) * cfg_.domain.Lz;
  }
  return c;
}

SimulationSnapshot Simulation::snapshot() const {
  SimulationSnapshot st;
  const std::size_t np = placements_.size(), n = s_.x.size();
  st.initial_centres.resize(3 * np);
  st.species.resize(np);
  st.pinned.resize(np);
  for (std::size_t k = 0; k < np; ++k) {
    for (int c = 0; c < 3; ++c) st.initial_centres[3 * k + c] = placements_[k].center[c];
    st.species[k] = placements_[k].species;
    st.pinned[k] = placements_[k].pinned ? 1 : 0;
  }
  // Orientations only when some capsule is turned: the checkpoints of sphere runs stay as they were.
  bool turned = false;
  for (const CapsulePlacement& p : placements_) turned = turned || p.orientation != kIdentityRotation;
  if (turned) {
    st.initial_orientations.resize(9 * np);
    for (std::size_t k = 0; k < np; ++k)
      for (std::size_t c = 0; c < 9; ++c) st.initial_orientations[9 * k + c] = placements_[k].orientation[c];
  }
  state();  // host-valid positions and history: the arrays a checkpoint writes
  for (const auto* v : {&uxp_, &uyp_, &uzp_, &uxpp_, &uypp_, &uzpp_}) ws_->host_read(*v);
  st.positions.resize(3 * n);
  st.u_previous.resize(3 * n);
  st.u_previous2.resize(3 * n);
  for (std::size_t i = 0; i < n; ++i) {
    st.positions[3 * i] = s_.x[i];
    st.positions[3 * i + 1] = s_.y[i];
    st.positions[3 * i + 2] = s_.z[i];
    st.u_previous[3 * i] = uxp_[i];
    st.u_previous[3 * i + 1] = uyp_[i];
    st.u_previous[3 * i + 2] = uzp_[i];
    st.u_previous2[3 * i] = uxpp_[i];
    st.u_previous2[3 * i + 1] = uypp_[i];
    st.u_previous2[3 * i + 2] = uzpp_[i];
  }
  st.pin_centres = pin_centre_;
  st.image = image_;
  st.time = time_;
  st.step = step_;
  st.dt_previous = dt_prev_;
  st.have_history = have_history_;
  st.have_history2 = have_history2_;
  st.contact_corrections = contact_corrections_;
  st.steps_with_contacts = steps_with_contacts_;
  st.unconverged_contacts = unconverged_contacts_;
  st.max_step_ratio_since_record = max_ratio_since_record_;
  // The guess of the solve at these positions (evaluated: the one it used; otherwise the one it will use) and the
  // answer before that solve, from which the run extrapolates on.
  if (double_layer_) {
    if (evaluated_) {
      st.interface_velocity = gmres_used_guess_;
      st.interface_velocity_previous = gmres_prev_answer_;
      st.interface_velocity_previous_time = gmres_prev_answer_time_;
    } else {
      if (!gmres_first_guess(time_, st.interface_velocity)) st.interface_velocity.clear();
      st.interface_velocity_previous = gmres_guess_;
      st.interface_velocity_previous_time = gmres_guess_time_;
    }
  }
  st.gmres_steps_since_record = gmres_since_record_.steps;
  st.gmres_iterations_since_record = gmres_since_record_.iterations;
  st.gmres_max_iterations_since_record = gmres_since_record_.max_iterations;
  st.gmres_max_residual_since_record = gmres_since_record_.max_residual;
  st.step_limits_since_record.assign(limits_since_record_.begin(), limits_since_record_.end());
  st.contact_events = contact_events_;
  return st;
}


void Simulation::set_positions(const std::vector<double>& x) {
  const std::size_t n = s_.x.size();
  if (x.size() != 3 * n) throw std::invalid_argument("Simulation::set_positions: expected 3 values per node");
  if (ws_->active()) throw std::logic_error("Simulation::set_positions: host backends only");
  for (std::size_t i = 0; i < n; ++i) {
    s_.x[i] = x[3 * i];
    s_.y[i] = x[3 * i + 1];
    s_.z[i] = x[3 * i + 2];
  }
  positions_changed();
}

std::vector<double> Simulation::positions() const {
  const CapsuleState& s = state();
  std::vector<double> x(3 * s.x.size());
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    x[3 * i] = s.x[i];
    x[3 * i + 1] = s.y[i];
    x[3 * i + 2] = s.z[i];
  }
  return x;
}

void Simulation::velocities_at(const std::vector<double>& x, std::vector<double>& u) {
  const std::size_t n = s_.x.size();
  const std::vector<double> keep = positions();
  set_positions(x);
  evaluate();
  u.resize(3 * n);
  for (std::size_t i = 0; i < n; ++i) {
    u[3 * i] = ux_[i];
    u[3 * i + 1] = uy_[i];
    u[3 * i + 2] = uz_[i];
  }
  set_positions(keep);
}

}  // namespace capsflow
