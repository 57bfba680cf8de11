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

// Work columns per mode, in complex values: rx, ry, rz, d(ry)/dy, rhs, p, dp, dv (N+1 each), then g and P
// (tau_stride each) for tau_solve_flat.
inline std::size_t complex_columns(int N) { return 8 * static_cast<std::size_t>(N + 1) + 2 * tau_stride(N); }
inline std::size_t factor_doubles(int N) { return 7 * 2 * static_cast<std::size_t>(tau_stride(N)); }

CAPSFLOW_DEVICE_BEGIN
// Mode q = i (nz/2+1) + jz: the same steps, in the same order, as SlitStokesPlan::solve_modes.
inline void solve_one_mode(int q, int nx, int nz, int N, double H, double ax, double az, double inv_nxz,
                           std::size_t cplane, C* spec, const C* wspec, const double* hom_phi, const double* hom_psi,
                           const double* hom_minv, const double* D, C* cs, double* fs) {
  const int np = N + 1;
  const int nzh = nz / 2 + 1;
  const int i = q / nzh, jz = q % nzh;
  const std::size_t col = static_cast<std::size_t>(q);
  const std::size_t field = static_cast<std::size_t>(np) * cplane;
  C* rx = cs;
  C* ry = cs + np;
  C* rz = cs + 2 * np;
  C* dry = cs + 3 * np;
  C* rhs = cs + 4 * np;
  C* p = cs + 5 * np;
  C* dp = cs + 6 * np;
  C* dv = cs + 7 * np;
  C* g = cs + 8 * np;
  C* P = g + tau_stride(N);
  C* r3[3] = {rx, ry, rz};
  // Chebyshev coefficients: DCT-I of the column, then (-1)^k / (N c_k) and the FFT normalisation.
  for (int c = 0; c < 3; ++c) {
    const C* src = spec + c * field + col;
    for (int k = 0; k <= N; ++k) {
      C s(0.0);
      const double* Dk = D + static_cast<std::size_t>(k) * np;
      for (int j = 0; j <= N; ++j) s += Dk[j] * src[static_cast<std::size_t>(j) * cplane];
      const double ck = (k == 0 || k == N) ? 2.0 : 1.0;
      const double sc = ((k % 2) ? -1.0 : 1.0) * inv_nxz / (N * ck);
      r3[c][k] = s * sc;
    }
  }
  cheb_derivative<C>(N, ry, H, dry);
  const int sx = i <= nx / 2 ? i : i - nx;
  const int ia = sx < 0 ? -sx : sx;
  const double kx = ax * sx, kz = az * jz;
  const bool unpaired_x = nx % 2 == 0 && i == nx / 2;
  const bool unpaired_z = nz % 2 == 0 && jz == nz / 2;
  // Unpaired Nyquist modes keep k^2 but drop the odd first-derivative factors (6.7).
  const C ikx = unpaired_x ? C(0.0) : C(0.0, kx);
  const C ikz = unpaired_z ? C(0.0) : C(0.0, kz);
  const double k2 = kx * kx + kz * kz;
  const C ub0 = wspec[0 * cplane + col] * inv_nxz, ubH = wspec[3 * cplane + col] * inv_nxz;
  const C vb0 = wspec[1 * cplane + col] * inv_nxz, vbH = wspec[4 * cplane + col] * inv_nxz;
  const C wb0 = wspec[2 * cplane + col] * inv_nxz, wbH = wspec[5 * cplane + col] * inv_nxz;
  TauFactorsRef fac;
  tau_factors_bind(N, fs, fac);
  if (sx == 0 && jz == 0) {
    // Mean mode (6.6): u0'' = -rho_x0/mu, w0'' = -rho_z0/mu, v0 = mean of its wall values.
    tau_factor_flat(N, 0.0, H, fac);
    for (int k = 0; k <= N; ++k) rhs[k] = -rx[k];
    tau_solve_flat<C>(fac, rhs, ub0, ubH, rx, g, P);
    for (int k = 0; k <= N; ++k) rhs[k] = -rz[k];
    tau_solve_flat<C>(fac, rhs, wb0, wbH, rz, g, P);
    for (int k = 0; k <= N; ++k) ry[k] = C(0.0);
    ry[0] = 0.5 * (vb0 + vbH);
  } else {
    tau_factor_flat(N, k2, H, fac);
    for (int k = 0; k <= N; ++k) rhs[k] = ikx * rx[k] + dry[k] + ikz * rz[k];
    tau_solve_flat<C>(fac, rhs, C(0.0), C(0.0), p, g, P);
    cheb_derivative<C>(N, p, H, dp);
    for (int k = 0; k <= N; ++k) rhs[k] = dp[k] - ry[k];
    tau_solve_flat<C>(fac, rhs, vb0, vbH, ry, g, P);
    for (int k = 0; k <= N; ++k) rhs[k] = ikx * p[k] - rx[k];
    tau_solve_flat<C>(fac, rhs, ub0, ubH, rx, g, P);
    for (int k = 0; k <= N; ++k) rhs[k] = ikz * p[k] - rz[k];
    tau_solve_flat<C>(fac, rhs, wb0, wbH, rz, g, P);
    cheb_derivative<C>(N, ry, H, dv);
    const C th0 = ikx * ub0 + cheb_value_bottom<C>(N, dv) + ikz * wb0;
    const C thH = ikx * ubH + cheb_value_top<C>(N, dv) + ikz * wbH;
    // Influence matrix: add c1 H1 + c2 H2 so that div u = 0 on both walls.
    const std::size_t h = static_cast<std::size_t>(ia) * nzh + jz;
    const double* mi = hom_minv + h * 4;
    const C c1 = -(mi[0] * th0 + mi[1] * thH);
    const C c2 = -(mi[2] * th0 + mi[3] * thH);
    const double* phi = hom_phi + h * np;
    const double* psi = hom_psi + h * np;
    for (int k = 0; k <= N; ++k) {
      const double sgn = (k % 2) ? -1.0 : 1.0;  // phi_2 = phi_1 reflected, psi_2 = -psi_1 reflected
      const C phic = c1 * phi[k] + c2 * (sgn * phi[k]);
      const C psic = c1 * psi[k] - c2 * (sgn * psi[k]);
      rx[k] += ikx * phic;
      ry[k] += psic;
      rz[k] += ikz * phic;
    }
  }
  // Back to the grid: DCT-I of X_k = (-1)^k a_k, halved for interior k, into the mode's column.
  for (int c = 0; c < 3; ++c) {
    C* dst = spec + c * field + col;
    const C* r = r3[c];
    for (int j = 0; j <= N; ++j) {
      C s(0.0);
      const double* Dj = D + static_cast<std::size_t>(j) * np;
      for (int k = 0; k <= N; ++k) {
        const double sc = ((k % 2) ? -1.0 : 1.0) * ((k == 0 || k == N) ? 1.0 : 0.5);
        s += Dj[k] * (r[k] * sc);
      }
      dst[static_cast<std::size_t>(j) * cplane] = s;
    }
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

void slit_solve_modes_device(const SlitModeGrid& g, double* spec, const double* wspec, const double* hom_phi,
                             const double* hom_psi, const double* hom_minv, const double* dct, double* scratch,
                             std::size_t chunk) {
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
  for (long long q0 = 0; q0 < nmodes; q0 += static_cast<long long>(chunk)) {
    const long long q1 = q0 + static_cast<long long>(chunk) < nmodes ? q0 + static_cast<long long>(chunk) : nmodes;
#pragma omp target teams distribute parallel for is_device_ptr(scratch)                                  \
    map(tofrom : spec[0:nspec]) map(to : wspec[0:nwspec], hom_phi[0:nhom], hom_psi[0:nhom], hom_minv[0:4 * nh], \
                                        dct[0:ndct])
    for (long long q = q0; q < q1; ++q) {
      double* base = scratch + static_cast<std::size_t>(q - q0) * per_mode;
      C* cs = reinterpret_cast<C*>(base);
      double* fs = base + 2 * ccols;
      solve_one_mode(static_cast<int>(q), nx, nz, N, H, ax, az, inv_nxz, cplane, reinterpret_cast<C*>(spec),
                     reinterpret_cast<const C*>(wspec), hom_phi, hom_psi, hom_minv, dct, cs, fs);
    }
  }
#else
  (void)g, (void)spec, (void)wspec, (void)hom_phi, (void)hom_psi, (void)hom_minv, (void)dct, (void)scratch, (void)chunk;
#endif
}

}  // namespace capsflow
