#pragma once
// The per-step loops of the time integration over flat node arrays (Simulation::advance, SingleLayerPlan;
// architecture review R7): one body per loop, run serially, by host threads, or in a target region on the device
// backend. They were host loops in Simulation; as kernels the device step keeps its arrays resident.
//
// Every body does the same arithmetic on every backend, so the serial results are what they were, bit for bit, and
// the threads and device backends equal them: element-wise updates, per-capsule sums in node order inside one
// thread, and reductions that are exact in any order (min, max, logical and). Device branches map their node arrays
// with map clauses: when a StepWorkspace has attached them, the clauses find them present and copy nothing.
#include <cstddef>

#include "kernels/backend.hpp"
#include "kernels/device_macros.hpp"

namespace capsflow {

// Imposed-flow codes (host/physics/config.hpp's FlowType, as plain ints for device code).
enum ImposedFlowCode : int { kImposedNone = 0, kImposedPoiseuille = 1, kImposedShear = 2 };

CAPSFLOW_DEVICE_BEGIN
// The undisturbed flow's x velocity at height y: Poiseuille rate y (1 - y/H), shear rate (y - H/2), or 0.
inline double imposed_flow_x(int code, double rate, double H, double y) {
  if (code == kImposedPoiseuille) return rate * y * (1.0 - y / H);
  if (code == kImposedShear) return rate * (y - 0.5 * H);
  return 0.0;
}
CAPSFLOW_DEVICE_END

// a[i] = b[i] = c[i] = value, i < n.
void fill3(Backend backend, std::size_t n, double value, double* a, double* b, double* c);
// dx = sx, dy = sy, dz = sz (n each).
void copy3(Backend backend, std::size_t n, const double* sx, const double* sy, const double* sz, double* dx,
           double* dy, double* dz);
// Variable-step Adams-Bashforth 2: x += dtp (a u + b up), per component (docs/method.md §4).
void ab2_update(Backend backend, std::size_t n, double dtp, double a, double b, const double* ux, const double* uy,
                const double* uz, const double* uxp, const double* uyp, const double* uzp, double* x, double* y,
                double* z);
// ux[i] += imposed_flow_x(code, rate, H, y[i]).
void add_imposed_flow_x(Backend backend, std::size_t n, int code, double rate, double H, const double* y,
                        double* ux);
// True when every entry of a, b and c is finite.
// max_i |u^n_i - 2 u^(n-1)_i + u^(n-2)_i| (Euclidean norm per node): the AB2 truncation proxy's second difference.
double max_second_difference(Backend backend, std::size_t n, const double* ux, const double* uy, const double* uz,
                             const double* vx, const double* vy, const double* vz, const double* wx, const double* wy,
                             const double* wz);

bool all_finite3(Backend backend, std::size_t n, const double* a, const double* b, const double* c);
// Smallest i with y[i] < lo or y[i] > hi (or NaN), -1 when there is none.
long first_outside(Backend backend, std::size_t n, const double* y, double lo, double hi);
// Largest element bounding radius (centroid to vertex) over ncap capsules sharing one mesh.
double max_element_radius(Backend backend, int ncap, int nv, int ntri, const int* tri, const double* x,
                          const double* y, const double* z);
// Mean of each capsule's nodes (3 per capsule: x, y, z), summed in node order.
void capsule_node_means(Backend backend, int ncap, int nv, const double* x, const double* y, const double* z,
                        double* mean);
// Rigid translation of capsules: node coordinate c of capsule k += off[3 k + c], only where that entry is non-zero
// (a capsule without an offset is left bit-identical).
void translate_capsules(Backend backend, int ncap, int nv, const double* off, double* x, double* y, double* z);
// One Newton step of the volume correction (Simulation, D11): per capsule delta = (volume0 - volume) / sum_i |w_i|,
// the sum in node order, then x_i += delta w_i / |w_i|.
void volume_correction_step(Backend backend, int ncap, int nv, const double* volume0, const double* volume,
                            const double* wx, const double* wy, const double* wz, double* x, double* y, double* z);

}  // namespace capsflow
