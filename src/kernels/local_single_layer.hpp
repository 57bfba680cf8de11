#pragma once
// Local part of GGEM for capsule membranes (docs/method_quadrature.md "Assembly over capsules"):
//     u_l(x) = scale * sum_{e near x} \int_e G_l(x - y) . f(y) dS_y,      scale = 1/(8 pi mu) normally,
// f linear over each flat triangle from its nodal values, minimum images in x and z (never in y).
//
// Element e is included when |min_image(c_e - x)| < cutoff + R_e, c_e its centroid and R_e its bounding radius
// (largest centroid-to-vertex distance), so every element with a point within the cutoff is integrated in full.
// Its three vertices are unwrapped about the target (v = x + min_image(v_raw - x)) before element_single_layer_add;
// when the target is a node of the element (target_node[p] equals one of its global vertex ids) that corner is passed
// as the singular vertex. Requires Lx, Lz > 2 (cutoff + max R_e), so the minimum image is the only one in range.
//
// The element cell list is built on the host from the centroids (counting sort, stable: elements keep increasing
// global id inside a cell; kernels/device_cells builds the same list on the device, resident there); the per-target sum is a gather visiting cells in a fixed order, so the serial, threads and
// device backends add the same elements with the same rules in the same order (serial and threads are bit-identical).
// On x86-64 hosts (builds without offload) the host traversal reads per-element data packed once per geometry and
// density (ElementPack below), skips
// cells beyond reach, and G_l is evaluated eight at a time with AVX-512 or four with AVX2 + FMA (chosen once per
// process at run time): same rules, rounding-level differences from the device path (docs/method_quadrature.md
// "Evaluation of G_l", "Host traversal").
//
// Usage:
//     ElementCellList cl;
//     build_element_cell_list(cl, Lx, H, Lz, cutoff, ncap, nv, ntri, mesh.tri.data(), x, y, z);
//     local_single_layer_velocity(Backend::Threads, cl, LocalSplit{alpha, cutoff, 1.0 / (8 * kPi)},
//                                 SurfaceView{ncap, nv, ntri, mesh.tri.data(), x, y, z}, Vec3In{fx, fy, fz},
//                                 QuadratureOrders{}, TargetView{n, x, y, z, node_ids /*0..n-1*/},
//                                 Vec3Out{ux, uy, uz});
// The cell list depends on the node positions only: rebuild it whenever the nodes move.
#include <cstddef>
#include <vector>

#include "kernels/backend.hpp"
#include "kernels/element_quadrature.hpp"
#include "kernels/surface_views.hpp"

namespace capsflow {

struct ElementCellList {
  int ncx = 1, ncy = 1, ncz = 1;
  double cx = 0.0, cy = 0.0, cz = 0.0;  // cell sizes (>= cutoff + max_radius)
  double Lx = 0.0, Lz = 0.0, H = 0.0;
  double max_radius = 0.0;              // largest element bounding radius
  std::vector<int> start;               // ncells + 1
  std::vector<int> elem;                // global element ids (capsule k, triangle t: k * ntri + t) sorted by cell
  std::vector<double> ex, ey, ez, er;   // centroid (unwrapped about vertex 0) and bounding radius, sorted order
  std::size_t size() const { return elem.size(); }
};

// The list's arrays as a view (host pointers).
inline ElementCellsView element_cells_view(const ElementCellList& cl) {
  return {cl.ncx, cl.ncy, cl.ncz, cl.cx, cl.cy, cl.cz, cl.Lx, cl.Lz, cl.start.data(),
          cl.elem.data(), cl.ex.data(), cl.ey.data(), cl.ez.data(), cl.er.data()};
}

// Builds the list for ncap capsules sharing one mesh (tri: 3 * ntri local node ids; x, y, z: ncap * nv nodes,
// possibly outside the box in x and z). Throws std::invalid_argument when Lx or Lz <= 2 (cutoff + max_radius) or an argument is invalid.
void build_element_cell_list(ElementCellList& cl, double Lx, double H, double Lz, double cutoff, int ncap, int nv,
                             int ntri, const int* tri, const double* x, const double* y, const double* z);

// The host traversal's per-element data in cell order (x86-64 builds without offload, element_pack_used()): the
// geometry once per geometry (pack_element_geometry: vertices as offsets from the element's centroid, so a target
// places them with the one minimum image of the centroid; longest edge; twice the area; global node ids for the
// singular test), the nodal densities once per density (pack_element_density), so several target sets (the nodes,
// the wall points) and several densities on one geometry read one pack. The portable and device traversals read the
// cell list and node arrays directly; there the pack stays empty.
struct PackedElement {
  double dv[9];    // vertex - centroid
  double f[9];     // nodal densities
  double h_e;      // longest edge
  double jac;      // twice the area
  int g[3];        // global node ids of the vertices (singular detection)
  int degenerate;  // twice area <= 1e-14 h_e^2: contributes nothing
};
struct ElementPack {
  std::vector<PackedElement> elements;  // cell order (cl.elem); empty where element_pack_used() is false
  bool with_density = false;
};
bool element_pack_used();
// Threads: parallel over the elements (same values as serial). Never on the device (nothing to pack there).
void pack_element_geometry(Backend backend, const ElementCellList& cl, int nv, int ntri, const int* tri,
                           const double* x, const double* y, const double* z, ElementPack& pack);
// The densities at the pack's vertices; throws std::invalid_argument when the pack is not from cl's geometry.
void pack_element_density(Backend backend, const ElementCellList& cl, const double* fx, const double* fy,
                          const double* fz, ElementPack& pack);

// Adds split.scale * (local single-layer velocity) at the targets to u. cl must have been built from the surface's
// positions and the same cutoff.
void local_single_layer_velocity(Backend backend, const ElementCellList& cl, const LocalSplit& split,
                                 const SurfaceView& surface, const Vec3In& f, const QuadratureOrders& q,
                                 const TargetView& targets, const Vec3Out& u);

// The same sum with the pack made by pack_element_geometry and pack_element_density from cl, the surface and f
// (the host traversal reads the pack; the others ignore it). The form without a pack packs per call.
void local_single_layer_velocity(Backend backend, const ElementCellList& cl, const ElementPack& pack,
                                 const LocalSplit& split, const SurfaceView& surface, const Vec3In& f,
                                 const QuadratureOrders& q, const TargetView& targets, const Vec3Out& u);

// The double layer's local sums on the host traversal (x86-64 builds without offload, where element_pack_used();
// throws std::invalid_argument elsewhere): with m == nullptr adds scale * W_l's element integrals of the pack's
// densities at the targets to u (local_double_layer_velocity's sum); else adds the unit densities' matrices
// to m[9 p + 3 c + d] (local_double_layer_matrix's; the pack needs no densities). The same elements, classes and
// rules as the portable traversal, the normal of each element from its target-centred vertices, W_l evaluated eight
// (AVX-512) or four (AVX2) points at a time: rounding-level differences from the portable and device paths.
void local_double_layer_batched(Backend backend, const ElementCellList& cl, const ElementPack& pack,
                                const LocalSplit& split, const QuadratureOrders& q, const TargetView& targets,
                                const Vec3Out& u, double* m);

}  // namespace capsflow
