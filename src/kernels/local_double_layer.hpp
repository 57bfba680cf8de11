#pragma once
// Local part of GGEM for the double layer of the capsule membranes (kernels/double_layer_kernels.hpp; docs/method.md
// "Double layer"):
//     k_l(x) = scale * sum_{e near x} \int_e W_l(x - y; q(y), n_e) dS_y,      scale = 1/(8 pi) normally,
// q linear over each flat triangle from its nodal values, n_e the triangle's outward normal, minimum images in x and
// z. The same cell list, element classes, rules and visiting order as the local single layer (local_target_sum of
// kernels/local_traversal.hpp), so serial and threads give the same bits; the device runs the same body.
#include <cstddef>

#include "kernels/backend.hpp"
#include "kernels/element_quadrature.hpp"
#include "kernels/local_single_layer.hpp"

namespace capsflow {

// Adds split.scale * k_l at the targets to u (targets.node: the singular element test). cl must be built from the
// surface's positions and the same cutoff.
void local_double_layer_velocity(Backend backend, const ElementCellList& cl, const LocalSplit& split,
                                 const SurfaceView& surface, const Vec3In& q_density, const QuadratureOrders& q,
                                 const TargetView& targets, const Vec3Out& u);

// The matrices of the unit densities: m[9 p + 3 c + d] += scale * (k_l for the density e_d on every node)_c at target
// p (the singularity subtraction's C_i; one traversal instead of three). On the device the targets must be
// membrane nodes (targets.node not null).
void local_double_layer_matrix(Backend backend, const ElementCellList& cl, const LocalSplit& split,
                               const SurfaceView& surface, const QuadratureOrders& q, const TargetView& targets,
                               double* m);

// The same two sums reading the pack on the host traversal (local_double_layer_batched, where element_pack_used()
// and the backend is not the device): pack made by pack_element_geometry from cl and the surface, and for the
// velocity by pack_element_density from q_density. Elsewhere the forms above (the pack is not read).
void local_double_layer_velocity(Backend backend, const ElementCellList& cl, const ElementPack& pack,
                                 const LocalSplit& split, const SurfaceView& surface, const Vec3In& q_density,
                                 const QuadratureOrders& q, const TargetView& targets, const Vec3Out& u);
void local_double_layer_matrix(Backend backend, const ElementCellList& cl, const ElementPack& pack,
                               const LocalSplit& split, const SurfaceView& surface, const QuadratureOrders& q,
                               const TargetView& targets, double* m);

}  // namespace capsflow
