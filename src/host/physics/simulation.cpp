// The implementation of simulation.hpp: Simulation, the time integration of a capsule suspension (physics only).
#include "host/physics/simulation.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "host/base/errors.hpp"
#include "host/base/printable.hpp"
#include "host/base/stopwatch.hpp"
#include "host/physics/key_blame.hpp"
#include "kernels/step_update.hpp"

namespace capsflow {

namespace {

// A double in a message: %g, never %f (a 1e300 would print as 300 digits).
std::string num(double v) { return format_significant(v, 6); }

// D1: Gs = mu gammadot a / Ca. CapsuleState sets Gs = a / Ca', so it is given Ca' = Ca / (mu gammadot).
double state_ca(const Config& c, double ca) { return ca / (c.domain.viscosity * c.flow.shear_rate); }

}  // namespace

Simulation::Simulation(const Config& cfg)
    : cfg_(cfg),
      s_(cfg.capsules.mesh_level, cfg.capsules.membrane),
      model_(cfg.domain, cfg.ggem, cfg.run.backend, quadrature_orders(cfg.quadrature)),
      integrator_(cfg.run.backend, cfg.flow.shear_rate),
      contact_(cfg_) {
  validate_run_config(cfg_);
  placements_ = place_capsules(cfg_);
  build_state();
  attach_workspace();
}

Simulation::~Simulation() = default;

Simulation::Simulation(const Config& cfg, const SimulationSnapshot& snap, const std::string& where)
    : cfg_(cfg),
      s_(cfg.capsules.mesh_level, cfg.capsules.membrane),
      model_(cfg.domain, cfg.ggem, cfg.run.backend, quadrature_orders(cfg.quadrature)),
      integrator_(cfg.run.backend, cfg.flow.shear_rate),
      contact_(cfg_) {
  validate_run_config(cfg_);
  const std::size_t np = snap.species.size();
  // No pin centres (a run started from another run's frame): the placement's, as a new run computes them.
  if (snap.initial_centres.size() != 3 * np || snap.pinned.size() != np || snap.image.size() != 2 * np ||
      (snap.pin_centres.size() != 3 * np && !snap.pin_centres.empty()))
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
  }
  // Each part takes back its own pieces.
  integrator_.restore(snap);
  pins_->restore(snap);
  contact_.restore(snap);
  tally_.restore(snap);
  model_.restore(snap, n);
  time_ = snap.time;
  step_ = snap.step;
  attach_workspace();
}

void Simulation::build_state() {
  // One CapsuleState species per configured species, in file order (species index = [[species]] index).
  for (std::size_t i = 0; i < cfg_.species.size(); ++i) {
    const SpeciesSpec& sp = cfg_.species[i];
    s_.add_species(SpeciesProperties{state_ca(cfg_, sp.ca), sp.bending_modulus, cfg_.species_membrane(i), sp.shape});
  }
  const std::size_t np = placements_.size();
  std::vector<char> pinned(np, 0);
  for (std::size_t k = 0; k < np; ++k) {
    const CapsulePlacement& p = placements_[k];
    s_.add_capsule(p.center, cfg_.species_radius(static_cast<std::size_t>(p.species)), p.species, p.orientation);
    pinned[k] = p.pinned ? 1 : 0;
  }
  forces_ = make_force_terms(s_);
  std::vector<const ForceTerm*> terms;
  for (const auto& t : forces_) terms.push_back(t.get());
  rule_ = TimeStepRule(cfg_, placements_, s_, std::move(terms));  // Ca_ref (checks [time] reference_ca), h_e
  // The pinned centre is the centre of mass of the initial (discrete) capsule, not the nominal centre.
  const CapsuleGeometry g = compute_geometry(s_, Backend::Serial);
  pins_ = std::make_unique<PinAndWrap>(cfg_, std::move(pinned), g.centroid);
  volume_ = std::make_unique<VolumeCorrection>(g.volume);
  const std::size_t n = s_.x.size();
  integrator_.reset(n);
  wx_.assign(n, 0.0);
  wy_.assign(n, 0.0);
  wz_.assign(n, 0.0);
  model_.configure(cfg_, placements_, s_);
  // Order (D11 revised): position projection before contact, so the contact control has the last word on gaps.
  constraints_.clear();
  if (cfg_.capsules.volume_correction) constraints_.push_back(volume_.get());
  constraints_.push_back(&contact_);
  constraints_.push_back(pins_.get());
  checks_ = standard_step_checks();
}

void Simulation::attach_workspace() {
  // Every array of the step at its final size first: the workspace keys arrays by their buffers.
  const std::size_t n = s_.x.size(), nc = static_cast<std::size_t>(s_.num_capsules());
  for (auto* v : {&s_.Fx, &s_.Fy, &s_.Fz, &s_.node_area, &s_.fx, &s_.fy, &s_.fz, &ux_, &uy_, &uz_}) v->resize(n);
  U_.resize(3 * nc);
  omega_.resize(3 * nc);
  ws_ = std::make_unique<StepWorkspace>(cfg_.run.backend);
  if (!ws_->active()) return;
  node_cells_ = std::make_unique<DeviceNodeCells>(cfg_.run.backend);
  StepWorkspace& ws = *ws_;
  // The order of attachment is the device's (and the transfer tests'): positions, history, velocities, saved x^n,
  // forces, volume gradients, capsule velocities.
  const char* xyz = "xyz";
  const auto add3 = [&](NodeVectors v, const std::string& name, bool suffix_only) {
    std::vector<double>* a[3] = {&v.x, &v.y, &v.z};
    for (int c = 0; c < 3; ++c) ws.add(*a[c], suffix_only ? std::string(1, xyz[c]) : name + "_" + xyz[c]);
  };
  add3({s_.x, s_.y, s_.z}, "", true);
  add3(integrator_.previous(), "u_previous", false);
  add3(integrator_.previous2(), "u_previous2", false);
  add3(uvec(), "u", false);
  {
    NodeVectors sv = integrator_.saved();
    ws.add(sv.x, "x_saved");
    ws.add(sv.y, "y_saved");
    ws.add(sv.z, "z_saved");
  }
  add3({s_.Fx, s_.Fy, s_.Fz}, "F", false);
  ws.add(s_.node_area, "node_area");
  add3({s_.fx, s_.fy, s_.fz}, "f", false);
  add3(wvec(), "volume_gradient", false);
  ws.add(U_, "capsule_velocity");
  ws.add(omega_, "capsule_rotation");
  // Read-only for the whole run: the mesh, the membrane reference data, per-capsule moduli and target volumes.
  const TriMesh& m = s_.mesh();
  ws.add_constant(m.tri, "mesh_tri");
  ws.add_constant(m.edges, "mesh_edges");
  ws.add_constant(m.inc_offsets, "mesh_inc_offsets");
  ws.add_constant(m.inc_tri, "mesh_inc_tri");
  ws.add_constant(m.inc_corner, "mesh_inc_corner");
  const MembraneReference ref = s_.reference();
  const std::size_t ne = nc * static_cast<std::size_t>(s_.triangles_per_capsule()) * sizeof(double);
  ws.add_range(ref.area0, ne, "reference_area", true);
  ws.add_range(ref.g1x, ne, "reference_g1x", true);
  ws.add_range(ref.g1y, ne, "reference_g1y", true);
  ws.add_range(ref.g2x, ne, "reference_g2x", true);
  ws.add_range(ref.g2y, ne, "reference_g2y", true);
  ws.add_constant(s_.shear_modulus(), "shear_modulus");
  ws.add_constant(s_.membrane_law(), "membrane_law");
  ws.add_constant(s_.skalak_c(), "skalak_c");
  ws.add_constant(volume_->target(), "initial_volume");
}

const CapsuleState& Simulation::state() const {
  ws_->host_read(s_.x);
  ws_->host_read(s_.y);
  ws_->host_read(s_.z);
  return s_;
}

void Simulation::evaluate() {
  if (evaluated_) return;
  const Backend b = cfg_.run.backend;
  StepWorkspace& w = *ws_;
  const auto t0 = std::chrono::steady_clock::now();
  for (auto* v : {&s_.x, &s_.y, &s_.z}) w.device_read(*v);
  for (auto* v : {&s_.Fx, &s_.Fy, &s_.Fz, &s_.node_area, &s_.fx, &s_.fy, &s_.fz}) w.device_overwrite(*v);
  for (const auto& term : forces_) term->add(s_, b);
  timings_.forces = seconds_since(t0);
  model_.velocities(s_, w, uvec(), wvec(), time_, timings_);
  for (auto* v : {&ux_, &uy_, &uz_}) w.device_read(*v);
  w.device_overwrite(U_);
  w.device_overwrite(omega_);
  compute_mean_velocity(s_, b, ux_, uy_, uz_, U_, omega_);
  evaluated_ = true;
}

void Simulation::fluid_velocity_at(std::size_t nt, const double* tx, const double* ty, const double* tz,
                                   const int* target_node, double* ux, double* uy, double* uz, int* capsule) {
  if (cfg_.run.backend == Backend::Device)
    throw std::logic_error("Simulation::fluid_velocity_at: host backends only");
  evaluate();
  model_.velocities_at(s_, nt, tx, ty, tz, target_node, ux, uy, uz, capsule);
}

double Simulation::min_node_distance(bool* between) const {
  return capsflow::min_node_distance(s_, current_geometry(geometry_backend()), cfg_.domain, cfg_.run.backend, *ws_,
                                     node_cells_.get(), between);
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
                                            cfg_.domain.Lz, cfg_.domain.H, rule_.near_contact_range(),
                                            cfg_.time.min_gap, cfg_.run.backend);
  closing_cached_ = evaluated_;
  return closing_cache_;
}

double Simulation::ab2_error_proxy() const {
  if (!evaluated_) return std::numeric_limits<double>::quiet_NaN();
  return integrator_.error_proxy(*ws_, ux_, uy_, uz_);
}

void Simulation::choose_step(StepInfo& info) {
  // The geometry first (both rules read it; the paper rule's distance search is bounded by its shortest edge).
  const CapsuleGeometry& g = current_geometry(geometry_backend());
  rule_.choose(info, StepView{g, [this](bool* between) { return min_node_distance(between); },
                              [this, &g] { return closing_limits_at(g.centroid); }, integrator_.have_history(),
                              integrator_.dt_previous()});
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
  if (model_.solve_failed()) {
    info.stop = StopReason::SolveNotConverged;
    info.message = model_.solve_failure() + " at strain " + num(time_) + " (step " + std::to_string(step_) + ")" +
                   (std::isfinite(model_.last_gmres().residual)
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
  info.message = rule_.below_floor(info, time_);
  if (!info.message.empty()) info.stop = StopReason::DtBelowFloor;
  return info;
}

std::string Simulation::next_step_problem() {
  const std::size_t n = s_.x.size();
  const Backend be = cfg_.run.backend;
  ws_->note_scalar_results(1);
  if (!all_finite3(be, n, s_.x.data(), s_.y.data(), s_.z.data())) return "a node position is not finite";
  evaluate();
  if (model_.solve_failed())
    return model_.solve_failure() + " at strain " + num(time_) +
           (std::isfinite(model_.last_gmres().residual)
                ? "; expected more operator applications (max_iterations, restart) or a looser tolerance"
                : "");
  ws_->note_scalar_results(1);
  if (!all_finite3(be, n, ux_.data(), uy_.data(), uz_.data()))
    return "the membrane forces give a non-finite node velocity at strain " + num(time_) +
           "; expected finite forces from " + membrane_keys(cfg_);
  StepInfo info;
  choose_step(info);
  const std::string refused = rule_.refuse(info);
  if (!refused.empty()) return refused;
  const double move = integrator_.max_move(*ws_, info.dt, uvec());
  if (!(move <= cfg_.domain.H))
    return "the time step " + num(info.dt) + " = " + rule_.explain(info) + " would move a node by " + num(move) +
           ", more than the slit height H = " + num(cfg_.domain.H) + "; expected a step that moves nodes by a "
           "fraction of an element (check [time] cfl, [time] reference_ca, [[species]] ca and [capsules] inflation)";
  return "";
}

StepInfo Simulation::advance_fixed(double dt) {
  evaluate();
  StepInfo info;
  info.dt = dt;
  if (integrator_.have_history()) info.ratio = dt / integrator_.dt_previous();
  return take_step(std::move(info));
}

StepInfo Simulation::take_step(StepInfo info) {
  StepWorkspace& w = *ws_;
  auto t0 = std::chrono::steady_clock::now();
  integrator_.save(s_, w);
  // The geometry and gap caches belong to x^n; evaluated_ stays until the step is kept (a stopped step restores x^n
  // and keeps u^n).
  geometry_cached_ = false;
  closing_cached_ = false;
  integrator_.update(s_, w, info.dt, uvec());
  timings_.update = seconds_since(t0);

  ConstraintContext cc{s_, w, cfg_.run.backend, geometry_backend(), wvec(), timings_};
  for (Constraint* c : constraints_) c->apply(cc, info);

  // Check before keeping: a bad step leaves x^n in place for the final checkpoint.
  StepCheckContext kc{s_, w, cfg_.run.backend, geometry_backend(), cfg_, model_.single_layer().grid().cutoff};
  for (const StepCheck& check : checks_) {
    std::string why;
    const StopReason bad = check(kc, info, why);
    if (bad == StopReason::None) continue;
    integrator_.restore(s_, w);
    info.stop = bad;
    info.message = why + " in the step from strain " + num(time_) + " (step " + std::to_string(step_) + ", dt " +
                   num(info.dt) + ")";
    return info;
  }

  integrator_.commit(w, uvec(), info.dt);
  tally_.count(info, model_.solves_interface_velocity() ? &model_.last_gmres() : nullptr);
  time_ += info.dt;
  for (Constraint* c : constraints_) c->commit(info, time_);
  ++step_;
  positions_changed();
  return info;
}

FlowDiagnostics Simulation::flow_diagnostics() const {
  for (const auto* v : {&s_.x, &s_.y, &s_.z, &s_.fx}) ws_->host_read(*v);
  // The interface velocity of these positions: the last solve's whole answer (the node velocities may have lost
  // their tangential part, drops, or been projected).
  if (model_.solves_interface_velocity() && evaluated_)
    return capsflow::flow_diagnostics(s_, cfg_, model_.interface_velocity(), model_.lambda());
  return capsflow::flow_diagnostics(s_, cfg_);
}

std::vector<double> Simulation::species_profile(int bins) const { return capsflow::species_profile(state(), cfg_, bins); }

CapsuleGeometry Simulation::geometry() const { return current_geometry(Backend::Serial); }

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
  state();  // host-valid positions (the integrator pulls its history)
  st.positions.resize(3 * n);
  for (std::size_t i = 0; i < n; ++i) {
    st.positions[3 * i] = s_.x[i];
    st.positions[3 * i + 1] = s_.y[i];
    st.positions[3 * i + 2] = s_.z[i];
  }
  integrator_.save(st, *ws_);
  pins_->save(st);
  contact_.save(st);
  tally_.save(st);
  // The guess of the solve at these positions (evaluated: the one it used; otherwise the one it will use) and the
  // answer before that solve, from which the run extrapolates on.
  model_.save(st, evaluated_, time_);
  st.time = time_;
  st.step = step_;
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
