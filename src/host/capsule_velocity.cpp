#include "host/capsule_velocity.hpp"

#include <chrono>
#include <numeric>

#include "host/backend_select.hpp"
#include "host/stopwatch.hpp"
#include "kernels/ggem_kernels.hpp"
#include "kernels/step_update.hpp"

namespace capsflow {
namespace {
int imposed_flow_code(FlowType t) {
  switch (t) {
    case FlowType::Poiseuille: return kImposedPoiseuille;
    case FlowType::Shear: return kImposedShear;
    case FlowType::None: return kImposedNone;
  }
  return kImposedNone;
}
}  // namespace

double imposed_velocity_x(const FlowOptions& flow, double H, double y) {
  return imposed_flow_x(imposed_flow_code(flow.type), flow.shear_rate, H, y);
}

CapsuleVelocitySolver::CapsuleVelocitySolver(const SlitGeometry& geo, const GgemOptions& opt, Backend backend,
                                             QuadratureOrders orders)
    : ggem_(geo, opt, backend), backend_(backend), orders_(orders) {
  require_backend(backend);
}

void CapsuleVelocitySolver::node_velocities(const CapsuleState& s, const FlowOptions& flow, std::vector<double>& ux,
                                            std::vector<double>& uy, std::vector<double>& uz, StepWorkspace* ws) {
  const auto t_start = std::chrono::steady_clock::now();
  const SlitGeometry& geo = ggem_.geometry();
  const GgemGrid& g = ggem_.grid();
  const std::size_t n = static_cast<std::size_t>(s.num_nodes());
  const int ncap = s.num_capsules(), nv = s.nodes_per_capsule(), ntri = s.triangles_per_capsule();
  const int* tri = s.mesh().tri.data();
  const double scale = 1.0 / (8.0 * kPi * geo.viscosity);
  const std::size_t nw = ggem_.wall_points(0).size();
  if (node_ids_.size() != n) {
    node_ids_.resize(n);
    std::iota(node_ids_.begin(), node_ids_.end(), 0);
  }
  for (auto& w : wall_u_) w.resize(nw);
  // Without a workspace the declarations below are no-ops (an inactive one).
  StepWorkspace none(Backend::Serial);
  StepWorkspace& w = ws != nullptr ? *ws : none;
  if (w.active() && !w.has(node_ids_.data())) {
    w.add_constant(node_ids_, "node_ids");
    w.add_constant(ggem_.wall_points(0), "wall_points_x");
    w.add_constant(ggem_.wall_points(1), "wall_points_y");
    w.add_constant(ggem_.wall_points(2), "wall_points_z");
    w.add(wall_u_[0], "wall_local_u_x");
    w.add(wall_u_[1], "wall_local_u_y");
    w.add(wall_u_[2], "wall_local_u_z");
  }
  ux.resize(n);
  uy.resize(n);
  uz.resize(n);
  for (auto* v : {&ux, &uy, &uz}) w.device_overwrite(*v);
  fill3(backend_, n, 0.0, ux.data(), uy.data(), uz.data());

  auto t0 = std::chrono::steady_clock::now();
  // The element cell list is binned on the host: the device step's one pull of the positions.
  for (const auto* v : {&s.x, &s.y, &s.z}) w.host_read(*v);
  build_element_cell_list(cells_, geo.Lx, geo.H, geo.Lz, g.cutoff, ncap, nv, ntri, tri, s.x.data(), s.y.data(),
                          s.z.data());
  for (const auto* v : {&s.fx, &s.fy, &s.fz}) w.device_read(*v);
  local_single_layer_velocity(backend_, cells_, g.alpha, g.cutoff, scale, ncap, nv, ntri, tri, s.x.data(),
                              s.y.data(), s.z.data(), s.fx.data(), s.fy.data(), s.fz.data(), orders_, n, s.x.data(),
                              s.y.data(), s.z.data(), node_ids_.data(), ux.data(), uy.data(), uz.data());
  timings_.local_nodes = seconds_since(t0);

  t0 = std::chrono::steady_clock::now();
  for (auto& v : wall_u_) w.device_overwrite(v);
  fill3(backend_, nw, 0.0, wall_u_[0].data(), wall_u_[1].data(), wall_u_[2].data());
  local_single_layer_velocity(backend_, cells_, g.alpha, g.cutoff, scale, ncap, nv, ntri, tri, s.x.data(),
                              s.y.data(), s.z.data(), s.fx.data(), s.fy.data(), s.fz.data(), orders_, nw,
                              ggem_.wall_points(0).data(), ggem_.wall_points(1).data(), ggem_.wall_points(2).data(),
                              nullptr, wall_u_[0].data(), wall_u_[1].data(), wall_u_[2].data());
  timings_.local_walls = seconds_since(t0);

  // Global part from nodal point forces F_i = f_i A_i (decision D3). On the device GgemSolver::apply_global's
  // kernels take the forces (f / mu), the wall data (their negative), the positions and the velocities through map
  // clauses that find them present: nothing crosses.
  t0 = std::chrono::steady_clock::now();
  for (const auto* v : {&s.Fx, &s.Fy, &s.Fz}) w.device_read(*v);
  for (const auto& v : wall_u_) w.device_read(v);
  const double* wall_local[3] = {wall_u_[0].data(), wall_u_[1].data(), wall_u_[2].data()};
  ggem_.apply_global(n, s.x.data(), s.y.data(), s.z.data(), s.Fx.data(), s.Fy.data(), s.Fz.data(), wall_local, n,
                     s.x.data(), s.y.data(), s.z.data(), ux.data(), uy.data(), uz.data());
  timings_.global = seconds_since(t0);

  add_imposed_flow_x(backend_, n, imposed_flow_code(flow.type), flow.shear_rate, geo.H, s.y.data(), ux.data());
  timings_.total = seconds_since(t_start);
}

}  // namespace capsflow
