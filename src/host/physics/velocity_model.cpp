// The implementation of velocity_model.hpp: the node velocities from the membranes' force density.
#include "host/physics/velocity_model.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <stdexcept>

#include "host/base/printable.hpp"
#include "host/base/stopwatch.hpp"
#include "kernels/capsule_geometry.hpp"
#include "kernels/ggem_kernels.hpp"
#include "kernels/step_update.hpp"

namespace capsflow {
namespace {

// A double in a message: %g, never %f (a 1e300 would print as 300 digits).
std::string num(double v) { return format_significant(v, 6); }

bool all_finite(const std::vector<double>& v) {
  for (double x : v)
    if (!std::isfinite(x)) return false;
  return true;
}

}  // namespace

int imposed_flow_code(FlowType t) {
  switch (t) {
    case FlowType::Poiseuille: return kImposedPoiseuille;
    case FlowType::Shear: return kImposedShear;
    case FlowType::None: return kImposedNone;
  }
  return kImposedNone;
}

QuadratureOrders quadrature_orders(const QuadratureOptions& q) {
  QuadratureOrders o;
  o.singular = q.singular;
  o.far_ratio = q.far_ratio;
  o.symmetric_ratio = q.symmetric_ratio;
  o.outer_ratio = q.symmetric_ratio;  // the outer band off
  o.mid_ratio = q.mid_ratio;
  o.regular_mid = q.regular_mid;
  o.regular_near = q.regular_near;
  o.near_ratio = q.near_ratio;
  o.near_angle = o.near_radial = q.near_points;
  o.kernel_degree = q.kernel_degree;
  return o;
}

VelocityModel::VelocityModel(const SlitGeometry& domain, const GgemOptions& ggem, Backend backend,
                             const QuadratureOrders& orders)
    : single_(domain, ggem, backend, orders) {}

// Issue 22: the double layer on the single layer's geometry, and the viscosity ratio per capsule.
void VelocityModel::configure(const Config& cfg, const std::vector<CapsulePlacement>& placements,
                              const CapsuleState& s) {
  cfg_ = &cfg;
  lambda_.assign(placements.size(), 1.0);
  for (std::size_t k = 0; k < placements.size(); ++k)
    lambda_[k] = cfg.species[static_cast<std::size_t>(placements[k].species)].viscosity_ratio;
  if (cfg.has_viscosity_contrast()) double_layer_ = std::make_unique<DoubleLayerPlan>(single_);
  for (MembraneLaw l : s.membrane_law()) has_drops_ = has_drops_ || l == MembraneLaw::SurfaceTension;
  nodes_ = s.x.size();
}

void VelocityModel::velocities(CapsuleState& s, StepWorkspace& ws, NodeVectors u, NodeVectors w, double t,
                               SimulationTimings& timings) {
  const Config& c = *cfg_;
  const auto t0 = std::chrono::steady_clock::now();
  single_.set_geometry(s, &ws);
  single_.apply(s, u.x, u.y, u.z);
  add_imposed_flow_x(c.run.backend, s.x.size(), imposed_flow_code(c.flow.type), c.flow.shear_rate, c.domain.H,
                     s.y.data(), u.x.data());
  if (double_layer_) solve_interface_velocity(s, ws, u, t, timings);
  if (has_drops_) normal_motion_of_drops(s, ws, u, w);
  const SingleLayerTimings& vt = single_.last_timings();
  timings.local_nodes = vt.set_geometry + vt.local_nodes;  // the cell list and the pack belong to the local sums
  timings.local_walls = vt.local_walls;
  timings.global = vt.global;
  timings.velocity_total = seconds_since(t0);
  if (c.capsules.velocity_projection) project(s, ws, u, w);
}

void VelocityModel::velocities_at(const CapsuleState& s, std::size_t nt, const double* tx, const double* ty,
                                  const double* tz, const int* target_node, double* ux, double* uy, double* uz,
                                  int* capsule) {
  const Config& c = *cfg_;
  single_.apply_at(NodeField{s.fx, s.fy, s.fz}, NodeField{s.Fx, s.Fy, s.Fz}, nt, tx, ty, tz, target_node, ux, uy,
                   uz);
  add_imposed_flow_x(single_.backend(), nt, imposed_flow_code(c.flow.type), c.flow.shear_rate, c.domain.H, ty, ux);
  const std::size_t nv = static_cast<std::size_t>(s.nodes_per_capsule());
  std::vector<int> inside;
  if (capsule == nullptr && double_layer_) {
    inside.resize(nt);
    capsule = inside.data();
  }
  if (capsule != nullptr) {
    // Without a viscosity contrast the model has no double layer: one on the same geometry answers the question.
    std::unique_ptr<DoubleLayerPlan> own;
    if (!double_layer_) {
      own = std::make_unique<DoubleLayerPlan>(single_);
      own->set_geometry();
    }
    capsule_of_points(double_layer_ ? *double_layer_ : *own, nv, nt, tx, ty, tz, target_node, capsule);
  }
  if (double_layer_) add_double_layer_at(nv, nt, tx, ty, tz, target_node, capsule, ux, uy, uz);
}

void VelocityModel::capsule_of_points(DoubleLayerPlan& dl, std::size_t nv, std::size_t nt, const double* tx,
                                      const double* ty, const double* tz, const int* target_node, int* capsule) {
  // K_d of the constant density (k + 1, 0, 0) on capsule k is -(k + 1) e_x inside capsule k and 0 outside, up to the
  // discretisation: rounded, it names the capsule. A node is on its own capsule.
  const std::size_t n = nodes_;
  std::vector<double> q[3] = {std::vector<double>(n), std::vector<double>(n, 0.0), std::vector<double>(n, 0.0)};
  for (std::size_t i = 0; i < n; ++i) q[0][i] = static_cast<double>(i / nv + 1);
  std::vector<double> k[3] = {std::vector<double>(nt), std::vector<double>(nt), std::vector<double>(nt)};
  dl.apply_discrete(NodeField{q[0], q[1], q[2]}, nt, tx, ty, tz, target_node, k[0].data(), k[1].data(),
                    k[2].data());
  const long ncap = static_cast<long>(n / nv);
  for (std::size_t p = 0; p < nt; ++p) {
    const long id = std::lround(-k[0][p]) - 1;
    capsule[p] = id >= 0 && id < ncap ? static_cast<int>(id) : -1;
    if (target_node != nullptr && target_node[p] >= 0) capsule[p] = static_cast<int>(target_node[p] / static_cast<long>(nv));
  }
}

void VelocityModel::add_double_layer_at(std::size_t nv, std::size_t nt, const double* tx, const double* ty,
                                        const double* tz, const int* target_node, const int* capsule, double* ux,
                                        double* uy, double* uz) {
  const std::size_t n = nodes_;
  if (guess_.size() != 3 * n) throw std::logic_error("VelocityModel::velocities_at before the interface solve");
  std::vector<double> q[3], k[3];
  for (int c = 0; c < 3; ++c) {
    q[c].resize(n);
    k[c].resize(nt);
    for (std::size_t i = 0; i < n; ++i) q[c][i] = (1.0 - lambda_[i / nv]) * guess_[c * n + i];
  }
  double_layer_->apply_deflated(NodeField{q[0], q[1], q[2]}, nt, tx, ty, tz, target_node, k[0].data(), k[1].data(),
                                k[2].data());
  double* u[3] = {ux, uy, uz};
  for (std::size_t p = 0; p < nt; ++p) {
    const int node = target_node != nullptr ? target_node[p] : -1;
    const double lam = capsule[p] >= 0 ? lambda_[static_cast<std::size_t>(capsule[p])] : 1.0;
    for (int c = 0; c < 3; ++c)
      u[c][p] = node >= 0 ? guess_[c * n + static_cast<std::size_t>(node)] : (u[c][p] + k[c][p]) / lam;
  }
}

void VelocityModel::solve_interface_velocity(CapsuleState& s, StepWorkspace& ws, NodeVectors u, double t,
                                             SimulationTimings& timings) {
  const auto t0 = std::chrono::steady_clock::now();
  // GMRES is host code: on the device backend the positions are read on both sides (the double layer's kernels find
  // them resident, its host parts read them here) and the velocity comes to the host, to go back after the solve.
  for (const auto* v : {&s.x, &s.y, &s.z}) ws.host_read(*v);
  for (auto* v : {&u.x, &u.y, &u.z}) ws.host_write(*v);
  double_layer_->set_geometry();
  const std::size_t n = s.x.size();
  const int nv = s.nodes_per_capsule();
  b_.resize(3 * n);
  x_.resize(3 * n);
  for (int c = 0; c < 3; ++c) {
    dl_q_[c].resize(n);
    dl_k_[c].resize(n);
  }
  const std::vector<double>* ui[3] = {&u.x, &u.y, &u.z};
  for (int c = 0; c < 3; ++c)
    for (std::size_t i = 0; i < n; ++i) b_[c * n + i] = (*ui[c])[i];
  // First guess: the last three answers extrapolated to this strain (the checkpoint keeps what a restart needs to
  // repeat the solve bit for bit); the first solve of a run starts from the right-hand side.
  const bool had_guess = first_guess(t, x_);
  if (!had_guess) x_ = b_;
  // A u = ((1 + lambda)/2) u - K~[(1 - lambda) u], lambda of each node's capsule.
  auto apply = [&](const double* in, double* out) {
    for (int c = 0; c < 3; ++c)
      for (std::size_t i = 0; i < n; ++i) dl_q_[c][i] = (1.0 - lambda_[i / nv]) * in[c * n + i];
    double_layer_->apply(NodeField{dl_q_[0], dl_q_[1], dl_q_[2]}, NodeFieldOut{dl_k_[0], dl_k_[1], dl_k_[2]});
    for (int c = 0; c < 3; ++c)
      for (std::size_t i = 0; i < n; ++i) out[c * n + i] = 0.5 * (1.0 + lambda_[i / nv]) * in[c * n + i] - dl_k_[c][i];
  };
  GmresOptions opt;
  opt.tolerance = cfg_->gmres.tolerance;
  opt.restart = cfg_->gmres.restart;
  opt.max_iterations = cfg_->gmres.max_iterations;
  // The guess this solve starts from (a snapshot taken before the step stores it: the restored run then repeats
  // this very solve), then the answer, the next solve's guess.
  // Empty for the right-hand side (the first solve): a checkpoint then stores no guess, as at step 0.
  if (had_guess)
    used_guess_ = x_;
  else
    used_guess_.clear();
  if (cfg_->gmres.rigid_preconditioner) {
    // Right preconditioning: A M y = b from y = M^-1 (the guess), then u = M y; GMRES tests |b - A u| as before.
    precond_.set_geometry(s.num_capsules(), nv, s.x.data(), s.y.data(), s.z.data(), lambda_);
    y_.resize(3 * n);
    my_.resize(3 * n);
    precond_.apply(x_.data(), y_.data(), true);
    auto apply_m = [&](const double* in, double* out) {
      precond_.apply(in, my_.data(), false);
      apply(my_.data(), out);
    };
    last_ = gmres(3 * n, apply_m, b_.data(), y_.data(), opt);
    precond_.apply(y_.data(), x_.data(), false);
  } else {
    last_ = gmres(3 * n, apply, b_.data(), x_.data(), opt);
  }
  forced_guess_.clear();
  prev2_answer_.swap(prev_answer_);
  prev2_answer_time_ = prev_answer_time_;
  prev_answer_.swap(guess_);
  prev_answer_time_ = guess_time_;
  guess_ = x_;
  guess_time_ = t;
  std::vector<double>* uo[3] = {&u.x, &u.y, &u.z};
  for (int c = 0; c < 3; ++c)
    for (std::size_t i = 0; i < n; ++i) (*uo[c])[i] = x_[c * n + i];
  timings.interface_solve = seconds_since(t0);
}

// The first guess of the interface solve at strain t: a restored checkpoint's own; else the last answers u1, u2, u3
// (strains t1 > t2 > t3) extrapolated to t by the parabola through them (Lagrange weights), or by the line through
// u1 and u2 while there are two. The answer moves smoothly with the suspension, so the extrapolation leaves an
// initial residual of O(dt^3) (quadratic) or O(dt^2) instead of O(dt): on set A at lambda 5, 1e-4 against 5e-4
// against 3e-2, one GMRES application fewer per step for each order (issue 34, docs/performance.md 15).
bool VelocityModel::first_guess(double t, std::vector<double>& x) const {
  const std::size_t m = 3 * nodes_;
  if (forced_guess_.size() == m) {
    x = forced_guess_;
    return true;
  }
  if (guess_.size() != m) return false;
  x.resize(m);
  const double t1 = guess_time_, t2 = prev_answer_time_;
  if (prev_answer_.size() != m || !(t1 > t2) || !(t > t1)) {
    std::copy(guess_.begin(), guess_.end(), x.begin());
    return true;
  }
  const double t3 = prev2_answer_time_;
  if (prev2_answer_.size() == m && t2 > t3) {
    const double w1 = (t - t2) * (t - t3) / ((t1 - t2) * (t1 - t3));
    const double w2 = (t - t1) * (t - t3) / ((t2 - t1) * (t2 - t3));
    const double w3 = (t - t1) * (t - t2) / ((t3 - t1) * (t3 - t2));
    for (std::size_t i = 0; i < m; ++i) x[i] = w1 * guess_[i] + w2 * prev_answer_[i] + w3 * prev2_answer_[i];
    return true;
  }
  const double r = (t - t1) / (t1 - t2);
  for (std::size_t i = 0; i < m; ++i) x[i] = guess_[i] + r * (guess_[i] - prev_answer_[i]);
  return true;
}

// A drop (law = "surface-tension") is only its shape: its nodes move with the normal component (u.n) n, so the mesh
// does not drift with the tangential flow (it has no in-plane stiffness to hold it). Area-weighted node normals.
void VelocityModel::normal_motion_of_drops(CapsuleState& s, StepWorkspace& ws, NodeVectors u, NodeVectors w) {
  for (const auto* v : {&s.x, &s.y, &s.z}) ws.host_read(*v);
  for (auto* v : {&u.x, &u.y, &u.z}) ws.host_write(*v);
  for (auto* v : {&w.x, &w.y, &w.z}) ws.host_overwrite(*v);
  compute_node_normals(s, Backend::Serial, w.x, w.y, w.z);
  const int nv = s.nodes_per_capsule();
  const auto& law = s.membrane_law();
  for (int k = 0; k < s.num_capsules(); ++k) {
    if (law[static_cast<std::size_t>(k)] != MembraneLaw::SurfaceTension) continue;
    for (std::size_t i = static_cast<std::size_t>(k) * nv; i < static_cast<std::size_t>(k + 1) * nv; ++i) {
      const double un = u.x[i] * w.x[i] + u.y[i] * w.y[i] + u.z[i] * w.z[i];
      u.x[i] = un * w.x[i];
      u.y[i] = un * w.y[i];
      u.z[i] = un * w.z[i];
    }
  }
}

void VelocityModel::project(CapsuleState& s, StepWorkspace& ws, NodeVectors u, NodeVectors w) {
  const Backend b = cfg_->run.backend;
  for (auto* v : {&w.x, &w.y, &w.z}) ws.device_overwrite(*v);
  for (auto* v : {&u.x, &u.y, &u.z}) ws.device_write(*v);
  const TriMesh& m = s.mesh();
  volume_gradient(b, s.num_capsules(), s.nodes_per_capsule(), m.tri.data(), m.inc_offsets.data(),
                  m.inc_tri.data(), s.x.data(), s.y.data(), s.z.data(), w.x.data(), w.y.data(), w.z.data());
  project_volume_rate(b, s.num_capsules(), s.nodes_per_capsule(), w.x.data(), w.y.data(), w.z.data(), u.x.data(),
                      u.y.data(), u.z.data());
}

bool VelocityModel::solve_failed() const { return double_layer_ && !last_.converged && all_finite(b_); }

// Why an interface-velocity solve from finite data did not converge, naming the key: a non-finite residual is the
// operator's overflow (the most extreme viscosity ratio: ((1 + lambda)/2) u - (1 - lambda) K[u]), which no cap
// mends; a finite one is the cap's.
std::string VelocityModel::solve_failure() const {
  const Config& c = *cfg_;
  const GmresResult& g = last_;
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

void VelocityModel::save(SimulationSnapshot& st, bool evaluated, double t) const {
  if (!double_layer_) return;
  if (evaluated) {
    st.interface_velocity = used_guess_;
    st.interface_velocity_previous = prev_answer_;
    st.interface_velocity_previous_time = prev_answer_time_;
    st.interface_velocity_previous2 = prev2_answer_;
    st.interface_velocity_previous2_time = prev2_answer_time_;
  } else {
    if (!first_guess(t, st.interface_velocity)) st.interface_velocity.clear();
    st.interface_velocity_previous = guess_;
    st.interface_velocity_previous_time = guess_time_;
    st.interface_velocity_previous2 = prev_answer_;
    st.interface_velocity_previous2_time = prev_answer_time_;
  }
  // Only a pair the restored run can use: the older answer needs the newer beside it.
  if (st.interface_velocity_previous.empty()) st.interface_velocity_previous2.clear();
}

void VelocityModel::restore(const SimulationSnapshot& st, std::size_t nodes) {
  // The checkpoint's guess starts the first solve (the uninterrupted run's very guess); the two answers before it
  // carry the extrapolation on. Older checkpoints have one previous answer (the next guess is then linear) or none
  // (the next solves start from the last answer).
  forced_guess_.clear();
  guess_.clear();
  prev_answer_.clear();
  prev2_answer_.clear();
  if (st.interface_velocity.size() == 3 * nodes) forced_guess_ = st.interface_velocity;
  if (st.interface_velocity_previous.size() == 3 * nodes) {
    guess_ = st.interface_velocity_previous;
    guess_time_ = st.interface_velocity_previous_time;
    if (st.interface_velocity_previous2.size() == 3 * nodes) {
      prev_answer_ = st.interface_velocity_previous2;
      prev_answer_time_ = st.interface_velocity_previous2_time;
    }
  }
}

}  // namespace capsflow
