// The implementation of mode_solve_device.hpp: the per-mode Chebyshev-tau solves on the device.
#include "kernels/mode_solve_device.hpp"

#include <cmath>

#include "kernels/device_complex.hpp"
#include "kernels/device_macros.hpp"
#include "kernels/dispatch.hpp"
#include "kernels/ggem_kernels.hpp"
#include "kernels/mode_solve.hpp"

namespace capsflow {
namespace {

using C = DeviceComplex;

// Work per mode, in complex values: rx, ry, rz (N+1 each), then the scratch of slit_modes_velocity for one mode.
inline std::size_t complex_columns(int N) {
  return 3 * static_cast<std::size_t>(N + 1) + slit_modes_work_doubles(N, 1) / 2;
}
inline std::size_t factor_doubles(int N) { return tau_lanes_doubles(N, 1); }

CAPSFLOW_DEVICE_BEGIN
// Forward DCT-I of one (field c, degree k, mode q) entry, with (-1)^k / (N c_k) and the FFT normalisation: the
// Chebyshev coefficient a_k of the mode's column of the spectra.
inline C forward_dct_entry(int c, int k, std::size_t q, int N, std::size_t cplane, double inv_nxz, const C* spec,
                           const double* D) {
  const int np = N + 1;
  const C* src = spec + static_cast<std::size_t>(c) * np * cplane + q;
  const double* Dk = D + static_cast<std::size_t>(k) * np;
  C s(0.0);
  for (int j = 0; j <= N; ++j) s += Dk[j] * src[static_cast<std::size_t>(j) * cplane];
  const double ck = (k == 0 || k == N) ? 2.0 : 1.0;
  const double sc = ((k % 2) ? -1.0 : 1.0) * inv_nxz / (N * ck);
  return s * sc;
}

// Inverse: the grid value of plane j from the scaled coefficients X_k.
inline C inverse_dct_entry(int c, int j, std::size_t q, int N, std::size_t cplane, const C* coef, const double* D) {
  const int np = N + 1;
  const C* src = coef + static_cast<std::size_t>(c) * np * cplane + q;
  const double* Dj = D + static_cast<std::size_t>(j) * np;
  C s(0.0);
  for (int k = 0; k <= N; ++k) s += Dj[k] * src[static_cast<std::size_t>(k) * cplane];
  return s;
}

// Mode q = i (nz/2+1) + jz between the two DCT kernels: slit_modes_velocity with one lane, the body
// SlitStokesPlan::solve_modes runs with 16.
inline void solve_one_mode(int q, int nx, int nz, int N, double H, double ax, double az, double inv_nxz,
                           std::size_t cplane, C* coef, const C* wspec, const double* hom_phi, const double* hom_psi,
                           const double* hom_minv, C* cs, double* fs) {
  const int np = N + 1;
  const int nzh = nz / 2 + 1;
  const int i = q / nzh, jz = q % nzh;
  const std::size_t col = static_cast<std::size_t>(q);
  C* rx = cs;
  C* ry = cs + np;
  C* rz = cs + 2 * np;
  double* work = reinterpret_cast<double*>(cs + 3 * np);
  // This mode's Chebyshev coefficients, from the forward DCT kernel ([field][k][mode]: adjacent threads, adjacent modes).
  for (int k = 0; k <= N; ++k) {
    rx[k] = coef[(0 * static_cast<std::size_t>(np) + k) * cplane + col];
    ry[k] = coef[(1 * static_cast<std::size_t>(np) + k) * cplane + col];
    rz[k] = coef[(2 * static_cast<std::size_t>(np) + k) * cplane + col];
  }
  const int sx = i <= nx / 2 ? i : i - nx;
  const int ia = sx < 0 ? -sx : sx;
  const std::size_t h = static_cast<std::size_t>(ia) * nzh + jz;
  const double kx = ax * sx, kz = az * jz;
  const double lambda = kx * kx + kz * kz;
  TauLanes fac;
  tau_lanes_bind(N, 1, fs, fac);
  tau_lanes_factor(&lambda, H, fac);
  // Wall values as (re, im) lane pairs: u, v, w at y = 0 and y = H.
  double wall[6][2];
  for (int c = 0; c < 3; ++c)
    for (int side = 0; side < 2; ++side) {
      const C v = wspec[(3 * side + c) * cplane + col] * inv_nxz;
      wall[2 * c + side][0] = v.re;
      wall[2 * c + side][1] = v.im;
    }
  const double kxe = nx % 2 == 0 && i == nx / 2 ? 0.0 : kx;
  const double kze = nz % 2 == 0 && jz == nz / 2 ? 0.0 : kz;
  const int mean = sx == 0 && jz == 0;
  const ModeLanes in =
      mode_lanes(1, &kxe, &kze, &mean, &wall[0][0], hom_phi + h * np, hom_psi + h * np, hom_minv + h * 4);
  slit_modes_velocity<1>(N, H, in, fac, reinterpret_cast<double*>(rx), reinterpret_cast<double*>(ry),
                         reinterpret_cast<double*>(rz), work);
  // Back: X_k = (-1)^k a_k, halved for interior k, the input of the inverse DCT kernel.
  for (int k = 0; k <= N; ++k) {
    const double sc = ((k % 2) ? -1.0 : 1.0) * ((k == 0 || k == N) ? 1.0 : 0.5);
    coef[(0 * static_cast<std::size_t>(np) + k) * cplane + col] = rx[k] * sc;
    coef[(1 * static_cast<std::size_t>(np) + k) * cplane + col] = ry[k] * sc;
    coef[(2 * static_cast<std::size_t>(np) + k) * cplane + col] = rz[k] * sc;
  }
}
CAPSFLOW_DEVICE_END

}  // namespace

std::size_t slit_mode_scratch_doubles(int N) { return 2 * complex_columns(N) + factor_doubles(N); }

void dct1_matrix(int N, double* D) {
  const int np = N + 1;
  for (int k = 0; k <= N; ++k)
    for (int j = 0; j <= N; ++j) {
      const int m = (j * k) % (2 * N);  // cos(pi m / N) with the argument reduced exactly
      const double w = (j == 0 || j == N) ? 1.0 : 2.0;
      D[static_cast<std::size_t>(k) * np + j] = w * std::cos(kPi * m / N);
    }
}

void slit_solve_modes_device(const SlitModeGrid& g, double* spec, double* coef, const double* wspec,
                             const double* hom_phi, const double* hom_psi, const double* hom_minv, const double* dct,
                             double* scratch, std::size_t chunk) {
  require_built(Backend::Device, "slit_solve_modes_device");
#ifdef CAPSFLOW_HAVE_OFFLOAD
  const int nx = g.nx, nz = g.nz, N = g.N, np = N + 1;
  const int nzh = nz / 2 + 1;
  const std::size_t cplane = static_cast<std::size_t>(nx) * nzh;
  const std::size_t nspec = 2 * 3 * static_cast<std::size_t>(np) * cplane;  // doubles
  const std::size_t nwspec = 2 * 6 * cplane;
  const std::size_t nh = static_cast<std::size_t>(nx / 2 + 1) * nzh;
  const std::size_t nhom = nh * np;
  const std::size_t ndct = static_cast<std::size_t>(np) * np;
  const double H = g.H, ax = 2.0 * kPi / g.Lx, az = 2.0 * kPi / g.Lz;
  const double inv_nxz = 1.0 / (static_cast<double>(nx) * nz);
  const std::size_t ccols = complex_columns(N);
  const std::size_t per_mode = slit_mode_scratch_doubles(N);
  const long long nmodes = static_cast<long long>(cplane);
  const long long nentries = 3LL * np * nmodes;  // (field, degree or plane, mode)
  C* S = reinterpret_cast<C*>(spec);
  C* A = reinterpret_cast<C*>(coef);
  // 1. Forward DCT-I along y, one thread per (field, k, mode): the spectra -> the coefficients.
#pragma omp target teams distribute parallel for map(to : spec[0:nspec], dct[0:ndct]) map(tofrom : coef[0:nspec])
  for (long long t = 0; t < nentries; ++t) {
    const std::size_t q = static_cast<std::size_t>(t % nmodes);
    const long long ck = t / nmodes;
    A[t] = forward_dct_entry(static_cast<int>(ck / np), static_cast<int>(ck % np), q, N, cplane, inv_nxz, S, dct);
  }
  // 2. The per-mode solves, in launches of at most `chunk` modes (the scratch rows).
  for (long long q0 = 0; q0 < nmodes; q0 += static_cast<long long>(chunk)) {
    const long long q1 = q0 + static_cast<long long>(chunk) < nmodes ? q0 + static_cast<long long>(chunk) : nmodes;
#pragma omp target teams distribute parallel for is_device_ptr(scratch) map(tofrom : coef[0:nspec]) \
    map(to : wspec[0:nwspec], hom_phi[0:nhom], hom_psi[0:nhom], hom_minv[0:4 * nh])
    for (long long q = q0; q < q1; ++q) {
      double* base = scratch + static_cast<std::size_t>(q - q0) * per_mode;
      solve_one_mode(static_cast<int>(q), nx, nz, N, H, ax, az, inv_nxz, cplane, reinterpret_cast<C*>(coef),
                     reinterpret_cast<const C*>(wspec), hom_phi, hom_psi, hom_minv, reinterpret_cast<C*>(base),
                     base + 2 * ccols);
    }
  }
  // 3. Inverse DCT-I, one thread per (field, plane, mode): the coefficients -> the spectra.
#pragma omp target teams distribute parallel for map(to : coef[0:nspec], dct[0:ndct]) map(tofrom : spec[0:nspec])
  for (long long t = 0; t < nentries; ++t) {
    const std::size_t q = static_cast<std::size_t>(t % nmodes);
    const long long cj = t / nmodes;
    S[t] = inverse_dct_entry(static_cast<int>(cj / np), static_cast<int>(cj % np), q, N, cplane, A, dct);
  }
#else
  (void)g, (void)spec, (void)coef, (void)wspec, (void)hom_phi, (void)hom_psi, (void)hom_minv, (void)dct, (void)scratch,
      (void)chunk;
#endif
}

}  // namespace capsflow
