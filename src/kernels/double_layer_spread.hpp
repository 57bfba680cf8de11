#pragma once
// Spreading of the double layer's global forcing onto the slit grid (docs/method.md "Double layer"): each density
// element (node m at y_m, density q_m, vector area a_m = (1/3) sum of its triangles' A_e n_e) deposits the body force
// and the mass source of its screened dipole,
//     b(x) += h(r) [q_m (a_m.r) + a_m (q_m.r)],   s(x) += (q_m.a_m) g(r),     r = x - y_m (minimum image in x, z),
// h = ggem_dl_dipole_profile, g = ggem_screen, at the grid points within the cutoff sphere and inside the slit (the
// part of a cloud beyond a wall is dropped, as for the single layer: the split stays exact). Serial and threads walk
// the planes in the same way (each plane owned by one thread, the sources in increasing order), so their sums agree
// bit for bit. The device backend deposits with atomics (a team per source): equal to serial to round-off.
#include <cstddef>

#include "kernels/backend.hpp"
#include "kernels/spread_interp.hpp"

namespace capsflow {

void spread_double_layer(Backend backend, const SlitGridView& g, double alpha, double cutoff, std::size_t ns,
                         const double* sx, const double* sy, const double* sz, const double* qx, const double* qy,
                         const double* qz, const double* ax, const double* ay, const double* az, double* bx,
                         double* by, double* bz, double* s);

// The same deposit on the host backends from the single layer's prepared stencils (prepare_spread for the same ns
// sources at the same positions, alpha and cutoff: the x, z Gaussian factors and the plane-major source lists, made
// once per geometry), each (plane, row) a contiguous run of z points, 8 per AVX-512 operation where the CPU has it
// (chosen once per process). Serial and threads give the same bits; the terms differ from spread_double_layer's by
// rounding (the Gaussian as the product of its prepared factors). Throws std::logic_error for the device backend or
// a workspace prepared for other sources.
void spread_double_layer_prepared(Backend backend, const SlitGridView& g, double alpha, double cutoff, std::size_t ns,
                                  const double* sx, const double* sy, const double* sz, const double* qx,
                                  const double* qy, const double* qz, const double* ax, const double* ay,
                                  const double* az, double* bx, double* by, double* bz, double* s,
                                  const SpreadWorkspace& ws);

}  // namespace capsflow
