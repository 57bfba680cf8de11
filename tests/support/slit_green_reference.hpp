#pragma once
// Independent exact reference for the Green's function of Stokes flow in a planar slit:
// no-slip walls at y = 0 and y = H, periodic in x (period Lx) and z (period Lz), viscosity mu,
// no mean pressure gradient. Computed by a Fourier series in (x, z) with a closed-form solution
// per mode (derivation in slit_green_reference.cpp). It shares no code with the GGEM solver.
//
// Accuracy contract (both families of functions below): every returned tensor entry G_ij has an
// absolute error below tol / (8 pi mu r), where r is the distance from the target to the nearest
// periodic image of the source (for the wall part: to the nearest image of the source mirrored in
// the nearer wall, see below); velocities: below tol |F| / (8 pi mu r). The truncation is chosen
// from a rigorous-style tail bound with a safety factor; rounding limits tol to about 1e-13.
// If the requested tolerance cannot be met within max_modes Fourier modes (targets in, or very
// near, the source plane y = y0 for the full velocity) the functions throw std::domain_error;
// they never return a silently inaccurate result.
#include <cstddef>

namespace capsflow::test {

struct SlitRefGeometry {
  double H, Lx, Lz, mu;
};

// Default cap on the number of Fourier modes summed (about 1-3 s of CPU).
inline constexpr std::size_t kSlitRefMaxModes = 30'000'000;

// Green's tensor G (u_i = G[i][j] F_j) of the slit at tgt for a unit point force at src, periodic
// images included. Requires 0 < src[1] < H and 0 <= tgt[1] <= H, tgt[1] != src[1].
void slit_green_tensor(const SlitRefGeometry& g, const double src[3], const double tgt[3], double G[3][3],
                       double tol = 1e-10, std::size_t max_modes = kSlitRefMaxModes);

// Velocity u at tgt from the point force F at src (periodic images included).
void slit_green_velocity(const SlitRefGeometry& g, const double src[3], const double F[3], const double tgt[3],
                         double u[3], double tol = 1e-10, std::size_t max_modes = kSlitRefMaxModes);

// Wall-induced ("regular") part: the slit Green's tensor minus the doubly periodic free-space
// Stokeslet with its plane-averaged (k = 0) Fourier mode removed, i.e.
//   G_slit = G_fs' + G_wall,  G_fs'(x) = (1/A) sum_{k != 0} exp(i k.(rho - rho0)) Ghat_Oseen(k, y - y0),
// where Ghat_Oseen(k, Y) is the 2D Fourier transform in (x, z) of the Oseen tensor. G_wall contains
// the k = 0 slit mode (the plane-averaged shear flow) and is smooth everywhere in 0 <= y <= H,
// including the source plane and the source point itself (wall corrections to self-mobilities).
// It converges like exp(-k min(y + y0, 2H - y - y0)). Accuracy: r in the contract above is the
// distance to the nearest periodic image of the source mirrored in the nearer wall.
// Note: G_fs' differs from the plain periodic Oseen image sum by the (divergent) k = 0 mode; for a
// large period L it equals the Oseen tensor of the nearest image plus an O(1/L) lattice correction.
void slit_green_wall_tensor(const SlitRefGeometry& g, const double src[3], const double tgt[3], double G[3][3],
                            double tol = 1e-10, std::size_t max_modes = kSlitRefMaxModes);
void slit_green_wall_velocity(const SlitRefGeometry& g, const double src[3], const double F[3],
                              const double tgt[3], double u[3], double tol = 1e-10,
                              std::size_t max_modes = kSlitRefMaxModes);

// Number of Fourier modes (k != 0) the full (wall_only = false) or wall-part evaluation would sum
// for this pair and tolerance (a cost estimate); throws like the evaluations when the tail bound
// cannot be met.
std::size_t slit_green_mode_count(const SlitRefGeometry& g, const double src[3], const double tgt[3], double tol,
                                  bool wall_only = false, std::size_t max_modes = kSlitRefMaxModes);

}  // namespace capsflow::test
