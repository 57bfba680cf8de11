#include "host/capsule_velocity.hpp"

#include <chrono>
#include <numeric>

#include "host/backend_select.hpp"
#include "host/stopwatch.hpp"
#include "kernels/ggem_kernels.hpp"

namespace capsflow {
double imposed_velocity_x(const FlowOptions& flow, double H, double y) {
  switch (flow.type) {
    case FlowType::Poiseuille: return flow.shear_rate * y * (1.0 - y / H);
    case FlowType::Shear: return flow.shear_rate * (y - 0.5 * H);
    case FlowType::None: return 0.0;
  }
  return 0.0;
}

CapsuleVelocitySolver::CapsuleVelocitySolver(const SlitGeometry& geo, const GgemOptions& opt, Backend backend,
                                             QuadratureOrders orders)
    : ggem_(geo, opt, backend), backend_(backend), orders_(orders) {
  require_backend(backend);
}

void CapsuleVelocitySolver::node_velocities(const CapsuleState& s, const FlowOptions& flow, std::vector<double>& ux,
                                            std::vector<double>& uy, std::vector<double>& uz) {
  const auto t_start = std::chrono::steady_clock::now();
  const SlitGeometry& geo = ggem_.geometry();
  const GgemGrid& g = ggem_.grid();
  const std::size_t n = static_cast<std::size_t>(s.num_nodes());
  const int ncap = s.num_capsules(), nv = s.nodes_per_capsule(), ntri = s.triangles_per_capsule();
  const int* tri = s.mesh().tri.data();
  const double scale = 1.0 / (8.0 * kPi * geo.viscosity);
  ux.assign(n, 0.0);
  uy.assign(n, 0.0);
  uz.assign(n, 0.0);
  if (node_ids_.size() != n) {
    node_ids_.resize(n);
    std::iota(node_ids_.begin(), node_ids_.end(), 0);
  }

  auto t0 = std::chrono::steady_clock::now();
  build_element_cell_list(cells_, geo.Lx, geo.H, geo.Lz, g.cutoff, ncap, nv, ntri, tri, s.x.data(), s.y.data(),
                          s.z.data());
  local_single_layer_velocity(backend_, cells_, g.alpha, g.cutoff, scale, ncap, nv, ntri, tri, s.x.data(),
                              s.y.data(), s.z.data(), s.fx.data(), s.fy.data(), s.fz.data(), orders_, n, s.x.data(),
                              s.y.data(), s.z.data(), node_ids_.data(), ux.data(), uy.data(), uz.data());
  timings_.local_nodes = seconds_since(t0);

  t0 = std::chrono::steady_clock::now();
  const std::size_t nw = ggem_.wall_points(0).size();
  for (auto& w : wall_u_) w.assign(nw, 0.0);
  local_single_layer_velocity(backend_, cells_, g.alpha, g.cutoff, scale, ncap, nv, ntri, tri, s.x.data(),
                              s.y.data(), s.z.data(), s.fx.data(), s.fy.data(), s.fz.data(), orders_, nw,
                              ggem_.wall_points(0).data(), ggem_.wall_points(1).data(), ggem_.wall_points(2).data(),
                              nullptr, wall_u_[0].data(), wall_u_[1].data(), wall_u_[2].data());
  timings_.local_walls = seconds_since(t0);

  // Global part from nodal point forces F_i = f_i A_i (decision D3).
  t0 = std::chrono::steady_clock::now();
  const double* wall_local[3] = {wall_u_[0].data(), wall_u_[1].data(), wall_u_[2].data()};
  ggem_.apply_global(n, s.x.data(), s.y.data(), s.z.data(), s.Fx.data(), s.Fy.data(), s.Fz.data(), wall_local, n,
                     s.x.data(), s.y.data(), s.z.data(), ux.data(), uy.data(), uz.data());
  timings_.global = seconds_since(t0);

  for (std::size_t i = 0; i < n; ++i) ux[i] += imposed_velocity_x(flow, geo.H, s.y[i]);
  timings_.total = seconds_since(t_start);
}

}  // namespace capsflow
