// The implementation of device_cells.hpp: the cell lists binned on the device.
#include "kernels/device_cells.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "kernels/device_macros.hpp"
#include "kernels/dispatch.hpp"
#include "kernels/ggem_kernels.hpp"

namespace capsflow {
namespace {

// Block count of the exclusive scan: each block's counts are summed and scanned by one thread, the block sums by
// one thread; 256 blocks keep both serial parts short for the few thousand cells of a run.
constexpr int kScanBlocks = 256;

void require_device(Backend backend, const char* what) {
  require_built(backend, what);
  if (backend != Backend::Device) throw std::invalid_argument(std::string(what) + ": for the device backend only");
}

// Gives v n entries, attached through m: an array is (re-)attached only when its length changes (the mirror keys
// arrays by address and length), so a list keeps its device copy between builds. Invariant: a non-empty vector
// managed here is attached.
template <class T>
void keep_attached(DeviceMirror& m, std::vector<T>& v, std::size_t n) {
  if (v.size() == n) return;
  if (!v.empty()) m.detach(v.data());
  v.clear();
  v.resize(n);
  if (n > 0) m.attach_bytes(v.data(), n * sizeof(T));
}

}  // namespace

void DeviceCountingSort::reserve(DeviceMirror& m, int ncell) {
  keep_attached(m, fill_, static_cast<std::size_t>(ncell));
  keep_attached(m, block_, static_cast<std::size_t>(kScanBlocks));
}

void DeviceCountingSort::sort(int ncell, std::size_t n, const int* cell, int* start, int* order) {
#ifdef CAPSFLOW_HAVE_OFFLOAD
  int* fill = fill_.data();
  int* block = block_.data();
  const long long nl = static_cast<long long>(n);
  const int nc1 = ncell + 1, nb = kScanBlocks, chunk = (ncell + kScanBlocks - 1) / kScanBlocks;
#pragma omp target teams distribute parallel for map(tofrom : start[0:nc1])
  for (int c = 0; c < nc1; ++c) start[c] = 0;
  // Counts, shifted by one: start[c + 1] = items in cell c.
#pragma omp target teams distribute parallel for map(to : cell[0:n]) map(tofrom : start[0:nc1])
  for (long long i = 0; i < nl; ++i) {
    const int c = cell[i] + 1;
#pragma omp atomic update
    start[c] += 1;
  }
  // Inclusive scan of start[1..ncell] in place: block sums, their exclusive scan (one thread), each block's scan.
#pragma omp target teams distribute parallel for map(to : start[0:nc1]) map(tofrom : block[0:nb])
  for (int b = 0; b < nb; ++b) {
    const int lo = b * chunk, hi = std::min(ncell, lo + chunk);
    int s = 0;
    for (int c = lo; c < hi; ++c) s += start[c + 1];
    block[b] = s;
  }
#pragma omp target map(tofrom : block[0:nb])
  {
    int run = 0;
    for (int b = 0; b < nb; ++b) {
      const int t = block[b];
      block[b] = run;
      run += t;
    }
  }
#pragma omp target teams distribute parallel for map(to : block[0:nb]) map(tofrom : start[0:nc1])
  for (int b = 0; b < nb; ++b) {
    const int lo = b * chunk, hi = std::min(ncell, lo + chunk);
    int run = block[b];
    for (int c = lo; c < hi; ++c) {
      run += start[c + 1];
      start[c + 1] = run;
    }
  }
#pragma omp target teams distribute parallel for map(to : start[0:nc1]) map(tofrom : fill[0:ncell])
  for (int c = 0; c < ncell; ++c) fill[c] = start[c];
  // Placement in arrival order (racy on a GPU), then each cell's slice sorted by id: the stable sort's order.
#pragma omp target teams distribute parallel for map(to : cell[0:n]) map(tofrom : fill[0:ncell], order[0:n])
  for (long long i = 0; i < nl; ++i) {
    const int c = cell[i];
    int s;
#pragma omp atomic capture
    s = fill[c]++;
    order[s] = static_cast<int>(i);
  }
#pragma omp target teams distribute parallel for map(to : start[0:nc1]) map(tofrom : order[0:n])
  for (int c = 0; c < ncell; ++c) {
    const int lo = start[c], hi = start[c + 1];
    for (int s = lo + 1; s < hi; ++s) {
      const int v = order[s];
      int j = s - 1;
      while (j >= lo && order[j] > v) {
        order[j + 1] = order[j];
        --j;
      }
      order[j + 1] = v;
    }
  }
#else
  (void)ncell;
  (void)n;
  (void)cell;
  (void)start;
  (void)order;
  device_not_built("DeviceCountingSort");
#endif
}

DeviceElementCells::DeviceElementCells(Backend backend) : mirror_(backend) {
  require_device(backend, "DeviceElementCells");
}

const ElementCellList& DeviceElementCells::build(double Lx, double H, double Lz, double cutoff, int ncap, int nv,
                                                 int ntri, const int* tri, const double* x, const double* y,
                                                 const double* z) {
  if (!(Lx > 0.0 && Lz > 0.0 && H > 0.0 && cutoff > 0.0) || ncap < 0 || nv < 0 || ntri < 0)
    throw std::invalid_argument("build_element_cell_list: invalid box, cutoff or sizes");
  const std::size_t ne = static_cast<std::size_t>(ncap) * static_cast<std::size_t>(ntri);
  const std::size_t nn = static_cast<std::size_t>(ncap) * static_cast<std::size_t>(nv);
  const std::size_t n3 = 3 * static_cast<std::size_t>(ntri);
  for (auto* v : {&cx_, &cy_, &cz_, &rad_}) keep_attached(mirror_, *v, ne);
  keep_attached(mirror_, cell_, ne);
  double max_r = 0.0;
#ifdef CAPSFLOW_HAVE_OFFLOAD
  const long long nel = static_cast<long long>(ne);
  double *cxs = cx_.data(), *cys = cy_.data(), *czs = cz_.data(), *rad = rad_.data();
#pragma omp target teams distribute parallel for map(to : tri[0:n3], x[0:nn], y[0:nn], z[0:nn]) \
    map(tofrom : cxs[0:ne], cys[0:ne], czs[0:ne], rad[0:ne], max_r) reduction(max : max_r)
  for (long long e = 0; e < nel; ++e) {
    element_centroid_radius(e, nv, ntri, tri, x, y, z, Lx, Lz, cxs[e], cys[e], czs[e], rad[e]);
    max_r = rad[e] > max_r ? rad[e] : max_r;
  }
#else
  (void)nn;
  (void)n3;
  (void)tri;
  (void)x;
  (void)y;
  (void)z;
#endif
  const double reach = cutoff + max_r;
  if (!(Lx > 2.0 * reach && Lz > 2.0 * reach))
    throw std::invalid_argument("build_element_cell_list: Lx and Lz must exceed 2 (cutoff + largest element radius)");
  ElementCellList& cl = cl_;
  cl.max_radius = max_r;
  size_cell_grid(cl, Lx, H, Lz, reach);
  const int ncell = cl.ncx * cl.ncy * cl.ncz;
  keep_attached(mirror_, cl.start, static_cast<std::size_t>(ncell) + 1);
  keep_attached(mirror_, cl.elem, ne);
  for (auto* v : {&cl.ex, &cl.ey, &cl.ez, &cl.er}) keep_attached(mirror_, *v, ne);
  sort_.reserve(mirror_, ncell);
#ifdef CAPSFLOW_HAVE_OFFLOAD
  {
    const int ncx = cl.ncx, ncy = cl.ncy, ncz = cl.ncz;
    const double csx = cl.cx, csy = cl.cy, csz = cl.cz;
    int* cell = cell_.data();
#pragma omp target teams distribute parallel for map(to : cxs[0:ne], cys[0:ne], czs[0:ne]) map(tofrom : cell[0:ne])
    for (long long e = 0; e < nel; ++e) cell[e] = slit_cell_of(cxs[e], cys[e], czs[e], csx, csy, csz, ncx, ncy, ncz);
    int* elem = cl.elem.data();
    sort_.sort(ncell, ne, cell, cl.start.data(), elem);
    double *ex = cl.ex.data(), *ey = cl.ey.data(), *ez = cl.ez.data(), *er = cl.er.data();
#pragma omp target teams distribute parallel for map(to : elem[0:ne], cxs[0:ne], cys[0:ne], czs[0:ne], rad[0:ne]) \
    map(tofrom : ex[0:ne], ey[0:ne], ez[0:ne], er[0:ne])
    for (long long s = 0; s < nel; ++s) {
      const int e = elem[s];
      ex[s] = cxs[e];
      ey[s] = cys[e];
      ez[s] = czs[e];
      er[s] = rad[e];
    }
  }
#endif
  return cl_;
}

const ElementCellList& DeviceElementCells::pull() {
  mirror_.pull_bytes(cl_.start.data(), cl_.start.size() * sizeof(int));
  if (!cl_.elem.empty()) {
    mirror_.pull_bytes(cl_.elem.data(), cl_.elem.size() * sizeof(int));
    for (auto* v : {&cl_.ex, &cl_.ey, &cl_.ez, &cl_.er}) mirror_.pull(v->data(), v->size());
  }
  return cl_;
}

DeviceNodeCells::DeviceNodeCells(Backend backend) : mirror_(backend) { require_device(backend, "DeviceNodeCells"); }

const SlitCells& DeviceNodeCells::build(double Lx, double H, double Lz, double min_cell, std::size_t n,
                                        const double* x, const double* y, const double* z) {
  if (!(Lx > 0.0 && H > 0.0 && Lz > 0.0 && min_cell > 0.0))
    throw std::invalid_argument("bin_points: the box and the cell size must be positive");
  SlitCells& cl = cl_;
  // bin_points' grid: about one point per cell at most.
  const double per_point = n > 0 ? std::cbrt(Lx * H * Lz / static_cast<double>(n)) : Lx;
  size_cell_grid(cl, Lx, H, Lz, std::max(min_cell, per_point));
  const int ncell = cl.ncx * cl.ncy * cl.ncz;
  keep_attached(mirror_, cl.start, static_cast<std::size_t>(ncell) + 1);
  keep_attached(mirror_, cl.cell, n);
  keep_attached(mirror_, cl.index, n);
  sort_.reserve(mirror_, ncell);
#ifdef CAPSFLOW_HAVE_OFFLOAD
  const int ncx = cl.ncx, ncy = cl.ncy, ncz = cl.ncz;
  const double csx = cl.cx, csy = cl.cy, csz = cl.cz;
  const long long nl = static_cast<long long>(n);
  int* cell = cl.cell.data();
#pragma omp target teams distribute parallel for map(to : x[0:n], y[0:n], z[0:n]) map(tofrom : cell[0:n])
  for (long long i = 0; i < nl; ++i) cell[i] = slit_cell_of(x[i], y[i], z[i], csx, csy, csz, ncx, ncy, ncz);
  sort_.sort(ncell, n, cell, cl.start.data(), cl.index.data());
#else
  (void)x;
  (void)y;
  (void)z;
#endif
  return cl_;
}

double DeviceNodeCells::min_node_distance_between_capsules(int nv, const double* x, const double* y, const double* z,
                                                           double limit) const {
  double best = limit * limit;
#ifdef CAPSFLOW_HAVE_OFFLOAD
  const SlitCells& cl = cl_;
  const std::size_t n = cl.cell.size(), nc1 = cl.start.size();
  const long long nl = static_cast<long long>(n);
  const int ncx = cl.ncx, ncy = cl.ncy, ncz = cl.ncz;
  const double Lx = cl.Lx, Lz = cl.Lz;
  const int* start = cl.start.data();
  const int* index = cl.index.data();
  const int* cell = cl.cell.data();
  // The host search's body (closest_other_capsule_d2, kernels/slit_cells.hpp): a min, exact in any order.
#pragma omp target teams distribute parallel for map(to : start[0:nc1], index[0:n], cell[0:n], x[0:n], y[0:n], \
                                                         z[0:n]) map(tofrom : best) reduction(min : best)
  for (long long i = 0; i < nl; ++i)
    best = closest_other_capsule_d2(i, nv, ncx, ncy, ncz, Lx, Lz, start, index, cell, x, y, z, best);
#else
  (void)nv;
  (void)x;
  (void)y;
  (void)z;
#endif
  return best < limit * limit ? std::sqrt(best) : std::numeric_limits<double>::infinity();
}

const SlitCells& DeviceNodeCells::pull() {
  mirror_.pull_bytes(cl_.start.data(), cl_.start.size() * sizeof(int));
  if (!cl_.cell.empty()) {
    mirror_.pull_bytes(cl_.cell.data(), cl_.cell.size() * sizeof(int));
    mirror_.pull_bytes(cl_.index.data(), cl_.index.size() * sizeof(int));
  }
  return cl_;
}

}  // namespace capsflow
