// The implementation of single_layer_plan.hpp: SingleLayerPlan, the velocity operator of the capsule membranes.
#include "host/solver/single_layer_plan.hpp"

#include <chrono>
#include <numeric>
#include <stdexcept>

#include "host/base/backend_select.hpp"
#include "host/base/stopwatch.hpp"
#include "kernels/ggem_kernels.hpp"
#include "kernels/step_update.hpp"

namespace capsflow {

SingleLayerPlan::SingleLayerPlan(const SlitGeometry& geo, const GgemOptions& opt, Backend backend,
                                 QuadratureOrders orders)
    : global_(geo, resolve_ggem_grid(geo, opt), backend),
      backend_(backend),
      orders_(orders),
      scale_(1.0 / (8.0 * kPi * geo.viscosity)) {
  require_backend(backend);
  if (backend == Backend::Device) device_cells_ = std::make_unique<DeviceElementCells>(backend);
  for (auto& w : wall_u_) w.resize(global_.num_wall_points());
}

void SingleLayerPlan::require_geometry(const char* what) const {
  if (state_ == nullptr) throw std::logic_error(std::string("SingleLayerPlan::") + what + " before set_geometry");
}

void SingleLayerPlan::set_geometry(const CapsuleState& s, StepWorkspace* ws) {
  const auto t0 = std::chrono::steady_clock::now();
  const SlitGeometry& geo = global_.geometry();
  const GgemGrid& g = global_.grid();
  const std::size_t n = static_cast<std::size_t>(s.num_nodes());
  state_ = &s;
  ws_ = ws != nullptr ? ws : &no_workspace_;
  StepWorkspace& w = *ws_;
  if (node_ids_.size() != n) {
    node_ids_.resize(n);
    std::iota(node_ids_.begin(), node_ids_.end(), 0);
  }
  if (w.active() && !w.has(node_ids_.data())) {
    w.add_constant(node_ids_, "node_ids");
    w.add_constant(global_.wall_points(0), "wall_points_x");
    w.add_constant(global_.wall_points(1), "wall_points_y");
    w.add_constant(global_.wall_points(2), "wall_points_z");
    w.add(wall_u_[0], "wall_local_u_x");
    w.add(wall_u_[1], "wall_local_u_y");
    w.add(wall_u_[2], "wall_local_u_z");
  }
  const int ncap = s.num_capsules(), nv = s.nodes_per_capsule(), ntri = s.triangles_per_capsule();
  const int* tri = s.mesh().tri.data();
  const double* x = w.device_read(s.x);
  const double* y = w.device_read(s.y);
  const double* z = w.device_read(s.z);
  // The element cell list: binned on the device from the resident positions on the device backend (one scalar, the
  // largest element radius, comes back), on the host otherwise; then the host traversal's packed geometry.
  if (device_cells_) {
    w.note_scalar_results(1);
    cl_ = &device_cells_->build(geo.Lx, geo.H, geo.Lz, g.cutoff, ncap, nv, ntri, tri, x, y, z);
  } else {
    build_element_cell_list(cells_, geo.Lx, geo.H, geo.Lz, g.cutoff, ncap, nv, ntri, tri, x, y, z);
    cl_ = &cells_;
    pack_element_geometry(backend_, cells_, nv, ntri, tri, x, y, z, pack_);
  }
  // The global part's point forces sit at the nodes: their spreading stencils depend on the positions only.
  global_.set_sources(n, x, y, z);
  timings_.set_geometry = seconds_since(t0);
}

void SingleLayerPlan::pack_density(NodeField f) {
  // The host traversal reads the density from the pack: once per application, for the nodes and the wall points
  // (a no-op in builds whose traversal reads the arrays, the offload builds among them).
  StepWorkspace& w = *ws_;
  pack_element_density(backend_, cells_, w.device_read(f.x), w.device_read(f.y), w.device_read(f.z), pack_);
}

void SingleLayerPlan::local_at_nodes(NodeField f, NodeFieldOut u) {
  require_geometry("local_at_nodes");
  const auto t0 = std::chrono::steady_clock::now();
  pack_density(f);
  local_nodes(f, u);
  timings_.local_nodes = seconds_since(t0);
}

void SingleLayerPlan::local_at_walls(NodeField f) {
  require_geometry("local_at_walls");
  const auto t0 = std::chrono::steady_clock::now();
  pack_density(f);
  local_walls(f);
  timings_.local_walls = seconds_since(t0);
}

void SingleLayerPlan::local_sum(NodeField f, std::size_t nt, const double* tx, const double* ty, const double* tz,
                                const int* target_node, double* ux, double* uy, double* uz) {
  const CapsuleState& s = *state_;
  StepWorkspace& w = *ws_;
  const GgemGrid& g = global_.grid();
  const double *fx = w.device_read(f.x), *fy = w.device_read(f.y), *fz = w.device_read(f.z);
  const double *x = w.device_read(s.x), *y = w.device_read(s.y), *z = w.device_read(s.z);
  local_single_layer_velocity(
      backend_, *cl_, pack_, LocalSplit{g.alpha, g.cutoff, scale_},
      SurfaceView{s.num_capsules(), s.nodes_per_capsule(), s.triangles_per_capsule(), s.mesh().tri.data(), x, y, z},
      Vec3In{fx, fy, fz}, orders_, TargetView{nt, tx, ty, tz, target_node}, Vec3Out{ux, uy, uz});
}

void SingleLayerPlan::local_nodes(NodeField f, NodeFieldOut u) {
  StepWorkspace& w = *ws_;
  const CapsuleState& s = *state_;
  const double *x = w.device_read(s.x), *y = w.device_read(s.y), *z = w.device_read(s.z);
  double *ux = w.device_write(u.x), *uy = w.device_write(u.y), *uz = w.device_write(u.z);
  local_sum(f, static_cast<std::size_t>(s.num_nodes()), x, y, z, node_ids_.data(), ux, uy, uz);
}

void SingleLayerPlan::local_walls(NodeField f) {
  StepWorkspace& w = *ws_;
  const std::size_t nw = global_.num_wall_points();
  double* wu[3];
  for (int c = 0; c < 3; ++c) wu[c] = w.device_overwrite(wall_u_[c]);
  fill3(backend_, nw, 0.0, wu[0], wu[1], wu[2]);
  local_sum(f, nw, global_.wall_points(0).data(), global_.wall_points(1).data(), global_.wall_points(2).data(),
            nullptr, wu[0], wu[1], wu[2]);
}

void SingleLayerPlan::global(NodeField F, NodeFieldOut u) {
  require_geometry("global");
  const auto t0 = std::chrono::steady_clock::now();
  const CapsuleState& s = *state_;
  StepWorkspace& w = *ws_;
  const std::size_t n = static_cast<std::size_t>(s.num_nodes());
  // On the device the global part's kernels take the forces (f / mu), the wall data (their negative), the positions
  // and the velocities through map clauses that find them present: nothing crosses.
  const double *Fx = w.device_read(F.x), *Fy = w.device_read(F.y), *Fz = w.device_read(F.z);
  const double *x = w.device_read(s.x), *y = w.device_read(s.y), *z = w.device_read(s.z);
  const double* wall_local[3] = {w.device_read(wall_u_[0]), w.device_read(wall_u_[1]), w.device_read(wall_u_[2])};
  double *ux = w.device_write(u.x), *uy = w.device_write(u.y), *uz = w.device_write(u.z);
  global_.set_walls(wall_local);
  global_.spread(Fx, Fy, Fz);
  global_.solve();
  global_.interpolate(n, x, y, z, ux, uy, uz);
  timings_.global = seconds_since(t0);
}

void SingleLayerPlan::apply(NodeField f, NodeField F, NodeFieldOut u) {
  require_geometry("apply");
  const auto t0 = std::chrono::steady_clock::now();
  const std::size_t n = static_cast<std::size_t>(state_->num_nodes());
  StepWorkspace& w = *ws_;
  u.x.resize(n);
  u.y.resize(n);
  u.z.resize(n);
  double *ux = w.device_overwrite(u.x), *uy = w.device_overwrite(u.y), *uz = w.device_overwrite(u.z);
  fill3(backend_, n, 0.0, ux, uy, uz);
  pack_density(f);
  local_nodes(f, u);
  timings_.local_nodes = seconds_since(t0);
  const auto t1 = std::chrono::steady_clock::now();
  local_walls(f);
  timings_.local_walls = seconds_since(t1);
  global(F, u);
  timings_.apply = seconds_since(t0);
}

void SingleLayerPlan::apply_at(NodeField f, NodeField F, std::size_t nt, const double* tx, const double* ty,
                               const double* tz, const int* target_node, double* ux, double* uy, double* uz) {
  require_geometry("apply_at");
  if (backend_ == Backend::Device) throw std::logic_error("SingleLayerPlan::apply_at: host backends only");
  const auto t0 = std::chrono::steady_clock::now();
  for (std::size_t p = 0; p < nt; ++p) ux[p] = uy[p] = uz[p] = 0.0;
  pack_density(f);
  local_sum(f, nt, tx, ty, tz, target_node, ux, uy, uz);
  timings_.local_nodes = seconds_since(t0);
  const auto t1 = std::chrono::steady_clock::now();
  local_walls(f);
  timings_.local_walls = seconds_since(t1);
  const auto t2 = std::chrono::steady_clock::now();
  const double* wall_local[3] = {wall_u_[0].data(), wall_u_[1].data(), wall_u_[2].data()};
  global_.set_walls(wall_local);
  global_.spread(F.x.data(), F.y.data(), F.z.data());  // at the nodes: the stencils of set_geometry
  global_.solve();
  global_.interpolate(nt, tx, ty, tz, ux, uy, uz);
  timings_.global = seconds_since(t2);
  timings_.apply = seconds_since(t0);
}

void SingleLayerPlan::apply(const CapsuleState& s, std::vector<double>& ux, std::vector<double>& uy,
                            std::vector<double>& uz) {
  if (&s != state_) throw std::logic_error("SingleLayerPlan::apply: the state is not the one of set_geometry");
  apply(NodeField{s.fx, s.fy, s.fz}, NodeField{s.Fx, s.Fy, s.Fz}, NodeFieldOut{ux, uy, uz});
}

}  // namespace capsflow
