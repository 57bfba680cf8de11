// The implementation of local_double_layer.hpp: the local part of GGEM for the membranes' double layer.
#include "kernels/local_double_layer.hpp"

#include <stdexcept>

#include "kernels/device_macros.hpp"
#include "kernels/dispatch.hpp"
#include "kernels/double_layer_kernels.hpp"
#include "kernels/local_traversal.hpp"

namespace capsflow {
namespace {

CAPSFLOW_DEVICE_BEGIN

// The element rule of the double layer for local_target_sum: the element's normal from its unwrapped vertices.
// kNear: the near-singular rules compiled in (NearRules: a device region per rule).
template <NearRules kNear = NearRules::Any>
struct DoubleLayerRule {
  double alpha;
  QuadratureOrders q;
  void operator()(const double* xt, const double* v, const double* f, int singular, double* acc) const {
    element_double_layer_add<kNear>(alpha, xt, v, f, singular, q, acc);
  }
};

template <class Rule>
inline void dl_target(const Rule& rule, const ElementCellsView& cells, double cutoff,
                      const SurfaceView& surface, const Vec3In& q, double scale, double px, double py, double pz,
                      int tnode, double& ux, double& uy, double& uz) {
  double acc[3] = {0.0, 0.0, 0.0};
  local_detail::local_target_sum(rule, cells, cutoff, surface, q, px, py, pz, tnode, acc);
  ux += scale * acc[0];
  uy += scale * acc[1];
  uz += scale * acc[2];
}

// The unit densities' element rule: the 3 x 3 matrix of one target into m (a per-target array of 9).
template <NearRules kNear = NearRules::Any>
struct DoubleLayerMatrixRule {
  double alpha;
  QuadratureOrders q;
  double* m;
  void operator()(const double* xt, const double* v, const double*, int singular, double*) const {
    element_double_layer_matrix_add<kNear>(alpha, xt, v, singular, q, m);
  }
};

// One target's row of the matrix pass. The rule ignores the nodal densities (its own are ones): the positions stand
// in for the density arrays.
template <NearRules kNear = NearRules::Any>
inline void dl_matrix_target(double alpha, const QuadratureOrders& q, const ElementCellsView& cells, double cutoff,
                             const SurfaceView& surface, double scale, double px, double py, double pz, int tnode,
                             double* m9) {
  double acc9[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
  const DoubleLayerMatrixRule<kNear> rule{alpha, q, acc9};
  double unused[3] = {0.0, 0.0, 0.0};
  local_detail::local_target_sum(rule, cells, cutoff, surface, Vec3In{surface.x, surface.y, surface.z}, px, py,
                                 pz, tnode, unused);
  for (int k = 0; k < 9; ++k) m9[k] += scale * acc9[k];
}

CAPSFLOW_DEVICE_END

#ifdef CAPSFLOW_HAVE_OFFLOAD
// The device regions of local_double_layer_velocity, for one near-singular rule.
template <NearRules kNear>
void dl_device(const ElementCellList& cl, const LocalSplit& split, const SurfaceView& surface, const Vec3In& q_density,
               const QuadratureOrders& q_in, const TargetView& targets, const Vec3Out& u) {
  const DoubleLayerRule<kNear> rule{split.alpha, q_in};
  const double cutoff = split.cutoff, scale = split.scale;
  const std::size_t nt = targets.n;
  const long long n = static_cast<long long>(nt);
  const double *tx = targets.x, *ty = targets.y, *tz = targets.z;
  const int* target_node = targets.node;
  double *ux = u.x, *uy = u.y, *uz = u.z;
  // The views' arrays one by one (a region translates mapped pointer variables); the views are rebuilt inside.
  const int ncx = cl.ncx, ncy = cl.ncy, ncz = cl.ncz;
  const double cx = cl.cx, cy = cl.cy, cz = cl.cz, Lx = cl.Lx, Lz = cl.Lz;
  const int* start = cl.start.data();
  const int* elem = cl.elem.data();
  const double *ex = cl.ex.data(), *ey = cl.ey.data(), *ez = cl.ez.data(), *er = cl.er.data();
  const int ncap = surface.ncap, nv = surface.nv, ntri = surface.ntri;
  const int* tri = surface.tri;
  const double *x = surface.x, *y = surface.y, *z = surface.z, *qx = q_density.x, *qy = q_density.y,
               *qz = q_density.z;
  const std::size_t ne = cl.size();
  const std::size_t nc = cl.start.size();
  const std::size_t nn = static_cast<std::size_t>(ncap) * static_cast<std::size_t>(nv);
  const std::size_t n3 = 3 * static_cast<std::size_t>(ntri);
  if (target_node != nullptr) {
    const int* tn = target_node;
#pragma omp target teams distribute parallel for firstprivate(rule)                                               \
  map(to : start[0:nc], elem[0:ne], ex[0:ne], ey[0:ne], ez[0:ne], er[0:ne], tri[0:n3], x[0:nn], y[0:nn], z[0:nn], \
          qx[0:nn], qy[0:nn], qz[0:nn], tx[0:nt], ty[0:nt], tz[0:nt], tn[0:nt])                                \
  map(tofrom : ux[0:nt], uy[0:nt], uz[0:nt])
    for (long long p = 0; p < n; ++p) {
      const ElementCellsView cells{ncx, ncy, ncz, cx, cy, cz, Lx, Lz, start, elem, ex, ey, ez, er};
      dl_target(rule, cells, cutoff, SurfaceView{ncap, nv, ntri, tri, x, y, z}, Vec3In{qx, qy, qz}, scale,
                tx[p], ty[p], tz[p], tn[p], ux[p], uy[p], uz[p]);
    }
  } else {
#pragma omp target teams distribute parallel for firstprivate(rule)                                               \
  map(to : start[0:nc], elem[0:ne], ex[0:ne], ey[0:ne], ez[0:ne], er[0:ne], tri[0:n3], x[0:nn], y[0:nn], z[0:nn], \
          qx[0:nn], qy[0:nn], qz[0:nn], tx[0:nt], ty[0:nt], tz[0:nt])                                          \
  map(tofrom : ux[0:nt], uy[0:nt], uz[0:nt])
    for (long long p = 0; p < n; ++p) {
      const ElementCellsView cells{ncx, ncy, ncz, cx, cy, cz, Lx, Lz, start, elem, ex, ey, ez, er};
      dl_target(rule, cells, cutoff, SurfaceView{ncap, nv, ntri, tri, x, y, z}, Vec3In{qx, qy, qz}, scale,
                tx[p], ty[p], tz[p], -1, ux[p], uy[p], uz[p]);
    }
  }
}

// The device region of local_double_layer_matrix, for one near-singular rule.
template <NearRules kNear>
void dl_matrix_device(const ElementCellList& cl, const LocalSplit& split, const SurfaceView& surface,
                      const QuadratureOrders& q, const TargetView& targets, double* m) {
  const double alpha = split.alpha, cutoff = split.cutoff, scale = split.scale;
  const std::size_t nt = targets.n;
  const long long n = static_cast<long long>(nt);
  const double *tx = targets.x, *ty = targets.y, *tz = targets.z;
  const int* target_node = targets.node;
  const int ncx = cl.ncx, ncy = cl.ncy, ncz = cl.ncz;
  const double cx = cl.cx, cy = cl.cy, cz = cl.cz, Lx = cl.Lx, Lz = cl.Lz;
  const int* start = cl.start.data();
  const int* elem = cl.elem.data();
  const double *ex = cl.ex.data(), *ey = cl.ey.data(), *ez = cl.ez.data(), *er = cl.er.data();
  const int ncap = surface.ncap, nv = surface.nv, ntri = surface.ntri;
  const int* tri = surface.tri;
  const double *x = surface.x, *y = surface.y, *z = surface.z;
  const std::size_t ne = cl.size();
  const std::size_t nc = cl.start.size();
  const std::size_t nn = static_cast<std::size_t>(ncap) * static_cast<std::size_t>(nv);
  const std::size_t n3 = 3 * static_cast<std::size_t>(ntri);
  const std::size_t n9 = 9 * nt;
  const int* tn = target_node;
#pragma omp target teams distribute parallel for firstprivate(q)                                                  \
  map(to : start[0:nc], elem[0:ne], ex[0:ne], ey[0:ne], ez[0:ne], er[0:ne], tri[0:n3], x[0:nn], y[0:nn], z[0:nn], \
          tx[0:nt], ty[0:nt], tz[0:nt], tn[0:nt]) map(tofrom : m[0:n9])
  for (long long p = 0; p < n; ++p) {
    const ElementCellsView cells{ncx, ncy, ncz, cx, cy, cz, Lx, Lz, start, elem, ex, ey, ez, er};
    dl_matrix_target<kNear>(alpha, q, cells, cutoff, SurfaceView{ncap, nv, ntri, tri, x, y, z}, scale, tx[p], ty[p],
                            tz[p], tn[p], m + 9 * p);
  }
}
#endif

}  // namespace

void local_double_layer_velocity(Backend backend, const ElementCellList& cl, const LocalSplit& split,
                                 const SurfaceView& surface, const Vec3In& q_density, const QuadratureOrders& q_in,
                                 const TargetView& targets, const Vec3Out& u) {
  require_built(backend, "local_double_layer_velocity");
  if (cl.size() != static_cast<std::size_t>(surface.ncap) * static_cast<std::size_t>(surface.ntri))
    throw std::invalid_argument("local_double_layer_velocity: cell list built for a different element count");
  const DoubleLayerRule<> rule{split.alpha, q_in};
  const double cutoff = split.cutoff, scale = split.scale;
  const std::size_t nt = targets.n;
  const long long n = static_cast<long long>(nt);
  const double *tx = targets.x, *ty = targets.y, *tz = targets.z;
  const int* target_node = targets.node;
  double *ux = u.x, *uy = u.y, *uz = u.z;
  if (backend == Backend::Device) {
#ifdef CAPSFLOW_HAVE_OFFLOAD
    // One region per near-singular rule (NearRules): each carries only the stack of the rule it runs.
    if (q_in.near_method == NearSingularMethod::Subdivision)
      dl_device<NearRules::Subdivision>(cl, split, surface, q_density, q_in, targets, u);
    else
      dl_device<NearRules::Projection>(cl, split, surface, q_density, q_in, targets, u);
#endif
    return;
  }
  const ElementCellsView cells = element_cells_view(cl);
#pragma omp parallel for schedule(dynamic, 16) if (backend == Backend::Threads)
  for (long long p = 0; p < n; ++p)
    dl_target(rule, cells, cutoff, surface, q_density, scale, tx[p], ty[p], tz[p], target_node ? target_node[p] : -1,
              ux[p], uy[p], uz[p]);
}

void local_double_layer_matrix(Backend backend, const ElementCellList& cl, const LocalSplit& split,
                               const SurfaceView& surface, const QuadratureOrders& q, const TargetView& targets,
                               double* m) {
  require_built(backend, "local_double_layer_matrix");
  if (cl.size() != static_cast<std::size_t>(surface.ncap) * static_cast<std::size_t>(surface.ntri))
    throw std::invalid_argument("local_double_layer_matrix: cell list built for a different element count");
  const double alpha = split.alpha, cutoff = split.cutoff, scale = split.scale;
  const std::size_t nt = targets.n;
  const long long n = static_cast<long long>(nt);
  const double *tx = targets.x, *ty = targets.y, *tz = targets.z;
  const int* target_node = targets.node;
  if (backend == Backend::Device) {
    // The device's cell list lives on the device only (kernels/device_cells): the pass has to run there.
    if (target_node == nullptr)
      throw std::invalid_argument("local_double_layer_matrix (device): the targets must be membrane nodes");
#ifdef CAPSFLOW_HAVE_OFFLOAD
    if (q.near_method == NearSingularMethod::Subdivision)
      dl_matrix_device<NearRules::Subdivision>(cl, split, surface, q, targets, m);
    else
      dl_matrix_device<NearRules::Projection>(cl, split, surface, q, targets, m);
#endif
    return;
  }
  const ElementCellsView cells = element_cells_view(cl);
#pragma omp parallel for schedule(dynamic, 16) if (backend == Backend::Threads)
  for (long long p = 0; p < n; ++p)
    dl_matrix_target(alpha, q, cells, cutoff, surface, scale, tx[p], ty[p], tz[p], target_node ? target_node[p] : -1,
                     m + 9 * p);
}

void local_double_layer_velocity(Backend backend, const ElementCellList& cl, const ElementPack& pack,
                                 const LocalSplit& split, const SurfaceView& surface, const Vec3In& q_density,
                                 const QuadratureOrders& q, const TargetView& targets, const Vec3Out& u) {
  if (backend != Backend::Device && element_pack_used()) {
    local_double_layer_batched(backend, cl, pack, split, q, targets, u, nullptr);
    return;
  }
  local_double_layer_velocity(backend, cl, split, surface, q_density, q, targets, u);
}

void local_double_layer_matrix(Backend backend, const ElementCellList& cl, const ElementPack& pack,
                               const LocalSplit& split, const SurfaceView& surface, const QuadratureOrders& q,
                               const TargetView& targets, double* m) {
  if (backend != Backend::Device && element_pack_used()) {
    local_double_layer_batched(backend, cl, pack, split, q, targets, Vec3Out{}, m);
    return;
  }
  local_double_layer_matrix(backend, cl, split, surface, q, targets, m);
}

}  // namespace capsflow
