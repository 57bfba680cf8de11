#pragma once
// Chebyshev-tau building blocks of the per-mode slit Stokes solve (method-spec 6.1, 6.4-6.5; docs/method.md).
//
// Convention (pitfall P7, fixed once here): the wall-normal coordinate maps to s = 2y/H - 1 in [-1, 1], so
// s = -1 is the wall y = 0 and s = +1 the wall y = H. A function is u(s) = sum_k a_k T_k(s), k = 0..N. The grid
// points are s_j = -cos(pi j / N), j = 0..N, so y_j = (H/2)(1 - cos(pi j/N)) increases with j and y_0 = 0.
// Then u(y = H) = sum_k a_k and u(y = 0) = sum_k (-1)^k a_k.
//
// Templated on the scalar (double or std::complex<double>): the operators are real, so complex data is solved
// with the same real recurrences.
#include <cstddef>
#include <vector>

#include "kernels/device_macros.hpp"

namespace capsflow {

CAPSFLOW_DEVICE_BEGIN
// Value at y = H (s = +1) and at y = 0 (s = -1) of a Chebyshev series of degree n.
template <class T>
inline T cheb_value_top(int n, const T* a) {
  T s = T(0);
  for (int k = 0; k <= n; ++k) s += a[k];
  return s;
}
template <class T>
inline T cheb_value_bottom(int n, const T* a) {
  T s = T(0);
  for (int k = 0; k <= n; ++k) s += (k % 2 ? -a[k] : a[k]);
  return s;
}

// Coefficients b of du/dy from those of u (degree n), on [0, H]: the standard backward recurrence in s,
// times ds/dy = 2/H.
template <class T>
inline void cheb_derivative(int n, const T* a, double H, T* b) {
  if (n == 0) {
    b[0] = T(0);
    return;
  }
  const double scale = 2.0 / H;
  b[n] = T(0);
  b[n - 1] = (2.0 * n) * a[n];
  for (int k = n - 1; k >= 1; --k) b[k - 1] = (k + 1 <= n ? b[k + 1] : T(0)) + (2.0 * k) * a[k];
  b[0] *= 0.5;
  for (int k = 0; k <= n; ++k) b[k] *= scale;
}

CAPSFLOW_DEVICE_END

// Scratch space for tau_helmholtz, sized once per thread.
template <class T>
struct TauWorkspace {
  std::vector<T> g, P;
  std::vector<double> h, Q;
  explicit TauWorkspace(int n = 0) { resize(n); }
  void resize(int n) {
    g.assign(n / 2 + 2, T(0));
    P.assign(n / 2 + 2, T(0));
    h.assign(n / 2 + 2, 0.0);
    Q.assign(n / 2 + 2, 0.0);
  }
};

// Solves u'' - lambda u = F on 0 <= y <= H with u(0) = bc0, u(H) = bcH, by the Chebyshev-tau method:
// a (out) and F (in) are Chebyshev coefficients of degree n. The tau equations
//   lam p_k a_{k-2} + (lam q_k - 1) a_k + lam r_k a_{k+2} = -(p_k F_{k-2} + q_k F_k + r_k F_{k+2}),  k = 2..n
// (lam, F scaled by (H/2)^2; p_k = c_{k-2}/(4k(k-1)), q_k = -e_{k+2}/(2(k^2-1)), r_k = e_{k+4}/(4k(k+1)))
// split by parity into two tridiagonal systems closed by one boundary row each; a backward sweep expresses
// every unknown through the first, which the boundary row then fixes. O(n), diagonally dominant for lam >= 0.
//
// The sweep's factors depend on (n, lambda, H) only, not on F or the boundary values: tau_factor computes them once
// and tau_solve applies them, so the four solves of one Fourier mode share one factorisation (tau_helmholtz = both;
// the same operations in the same order, so the split changes no bit).
// Flat form of the factors, for device code: raw pointers into caller-owned storage of 7 * 2 * tau_stride(n) doubles
// (p, q, r, up, den, h, Q in that order; den holds the reciprocal of the eliminated diagonal). The vector-owning TauFactors below calls the same bodies.
CAPSFLOW_DEVICE_BEGIN
inline int tau_stride(int n) { return n / 2 + 2; }

struct TauFactorsRef {
  int n = -1;
  double h2 = 0.0;
  int M[2] = {0, 0};          // unknowns per parity
  double sumQ[2] = {1.0, 1.0};
  int stride = 0;             // rows per parity in the arrays below (row m of parity par at par * stride + m)
  double *p = nullptr, *q = nullptr, *r = nullptr, *up = nullptr, *den = nullptr, *h = nullptr, *Q = nullptr;
};

// Points f's arrays into storage (7 * 2 * tau_stride(n) doubles).
inline void tau_factors_bind(int n, double* storage, TauFactorsRef& f) {
  const int s2 = 2 * tau_stride(n);
  f.stride = tau_stride(n);
  f.p = storage;
  f.q = storage + s2;
  f.r = storage + 2 * s2;
  f.up = storage + 3 * s2;
  f.den = storage + 4 * s2;
  f.h = storage + 5 * s2;
  f.Q = storage + 6 * s2;
}

inline void tau_factor_flat(int n, double lambda, double H, TauFactorsRef& f) {
  f.n = n;
  f.h2 = 0.25 * H * H;
  const double lam = lambda * f.h2;
  f.stride = tau_stride(n);
  const int s2 = 2 * f.stride;
  for (int t = 0; t < s2; ++t) f.p[t] = f.q[t] = f.r[t] = f.up[t] = f.den[t] = f.h[t] = f.Q[t] = 0.0;
  for (int par = 0; par < 2; ++par) {
    const int M = (n - par) / 2 + 1;
    f.M[par] = M;
    double* p = f.p + par * f.stride;
    double* q = f.q + par * f.stride;
    double* r = f.r + par * f.stride;
    double* up = f.up + par * f.stride;
    double* den = f.den + par * f.stride;
    double* h = f.h + par * f.stride;
    double* Q = f.Q + par * f.stride;
    double h_next = 0.0;
    for (int m = M - 1; m >= 1; --m) {
      const int k = par + 2 * m;
      const double kk = k;
      p[m] = (k - 2 == 0 ? 2.0 : 1.0) / (4.0 * kk * (kk - 1.0));
      q[m] = -(k + 2 <= n ? 1.0 : 0.0) / (2.0 * (kk * kk - 1.0));
      r[m] = (k + 4 <= n ? 1.0 : 0.0) / (4.0 * kk * (kk + 1.0));
      const double lo = lam * p[m], di = lam * q[m] - 1.0;
      up[m] = lam * r[m];
      // The reciprocal, so the solves' backward sweeps (four per mode, a dependency chain) multiply instead of
      // dividing.
      den[m] = 1.0 / (di + up[m] * h_next);
      h[m] = -lo * den[m];
      h_next = h[m];
    }
    Q[0] = 1.0;
    double sumQ = 1.0;
    for (int m = 1; m < M; ++m) {
      Q[m] = h[m] * Q[m - 1];
      sumQ += Q[m];
    }
    f.sumQ[par] = sumQ;
  }
}

// g and P: scratch of tau_stride(n) values each.
template <class T>
inline void tau_solve_flat(const TauFactorsRef& f, const T* F, T bc0, T bcH, T* a, T* g, T* P) {
  const int n = f.n;
  const double h2 = f.h2;
  for (int par = 0; par < 2; ++par) {
    const int M = f.M[par];
    const double* p = f.p + par * f.stride;
    const double* q = f.q + par * f.stride;
    const double* r = f.r + par * f.stride;
    const double* up = f.up + par * f.stride;
    const double* den = f.den + par * f.stride;
    const double* h = f.h + par * f.stride;
    const double* Q = f.Q + par * f.stride;
    const T bc = par == 0 ? 0.5 * (bcH + bc0) : 0.5 * (bcH - bc0);
    // Backward sweep over the rows m = M-1 .. 1 (k = par + 2m): x_m = g_m + h_m x_{m-1}.
    T g_next = T(0);
    for (int m = M - 1; m >= 1; --m) {
      const int k = par + 2 * m;
      const T Fm = k - 2 <= n ? F[k - 2] * h2 : T(0);
      const T F0 = k <= n ? F[k] * h2 : T(0);
      const T Fp = k + 2 <= n ? F[k + 2] * h2 : T(0);
      const T rhs = -(p[m] * Fm + q[m] * F0 + r[m] * Fp);
      g[m] = (rhs - up[m] * g_next) * den[m];
      g_next = g[m];
    }
    // Forward: x_m = P_m + Q_m x_0; the boundary row sum_m x_m = bc fixes x_0.
    P[0] = T(0);
    T sumP = T(0);
    for (int m = 1; m < M; ++m) {
      P[m] = g[m] + h[m] * P[m - 1];
      sumP += P[m];
    }
    const T x0 = (bc - sumP) / f.sumQ[par];
    for (int m = 0; m < M; ++m) a[par + 2 * m] = P[m] + Q[m] * x0;
  }
}

// One Fourier mode of the slit solve between the two Chebyshev transforms (method-spec 6.5-6.7), for the CPU plan
// (C = std::complex<double>) and the device kernel (C = DeviceComplex) alike. In: rx, ry, rz the Chebyshev
// coefficients of rho/mu; the wall values of the mode; for k != 0 its homogeneous solutions phi_1, psi_1 (N + 1 each)
// and inverse influence matrix minv (4). Out: rx, ry, rz the velocity's coefficients. Scratch: dry, rhs, p, dp, dv
// (N + 1 each), g and P (tau_stride(N) each), fac bound to 7 * 2 * tau_stride(N) doubles.
template <class C>
inline void slit_mode_velocity(int N, double H, bool mean_mode, double kx, double kz, bool unpaired_x, bool unpaired_z,
                               C ub0, C ubH, C vb0, C vbH, C wb0, C wbH, const double* phi, const double* psi,
                               const double* minv, TauFactorsRef& fac, C* rx, C* ry, C* rz, C* dry, C* rhs, C* p,
                               C* dp, C* dv, C* g, C* P) {
  cheb_derivative<C>(N, ry, H, dry);
  if (mean_mode) {
    // Mean mode (6.6): u0'' = -rho_x0/mu, w0'' = -rho_z0/mu, v0 = mean of its wall values.
    tau_factor_flat(N, 0.0, H, fac);
    for (int k = 0; k <= N; ++k) rhs[k] = -rx[k];
    tau_solve_flat<C>(fac, rhs, ub0, ubH, rx, g, P);
    for (int k = 0; k <= N; ++k) rhs[k] = -rz[k];
    tau_solve_flat<C>(fac, rhs, wb0, wbH, rz, g, P);
    for (int k = 0; k <= N; ++k) ry[k] = C(0.0);
    ry[0] = 0.5 * (vb0 + vbH);
    return;
  }
  // Unpaired Nyquist modes keep k^2 but drop the odd first-derivative factors (6.7).
  const C ikx = unpaired_x ? C(0.0) : C(0.0, kx);
  const C ikz = unpaired_z ? C(0.0) : C(0.0, kz);
  const double k2 = kx * kx + kz * kz;
  // Particular solution: pressure with p = 0 on the walls, then the three velocity components (the solution
  // overwrites the forcing columns: u -> rx, v -> ry, w -> rz; dry is consumed first).
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
  const C c1 = -(minv[0] * th0 + minv[1] * thH);
  const C c2 = -(minv[2] * th0 + minv[3] * thH);
  for (int k = 0; k <= N; ++k) {
    const double sgn = (k % 2) ? -1.0 : 1.0;  // phi_2 = phi_1 reflected, psi_2 = -psi_1 reflected
    const C phic = c1 * phi[k] + c2 * (sgn * phi[k]);
    const C psic = c1 * psi[k] - c2 * (sgn * psi[k]);
    rx[k] += ikx * phic;
    ry[k] += psic;
    rz[k] += ikz * phic;
  }
}
CAPSFLOW_DEVICE_END

// The host form: owns its arrays (one factorisation per mode, shared by its four solves).
struct TauFactors {
  std::vector<double> storage;
  TauFactorsRef ref;
};

inline void tau_factor(int n, double lambda, double H, TauFactors& f) {
  f.storage.assign(7 * 2 * static_cast<std::size_t>(tau_stride(n)), 0.0);
  tau_factors_bind(n, f.storage.data(), f.ref);
  tau_factor_flat(n, lambda, H, f.ref);
}

template <class T>
inline void tau_solve(const TauFactors& f, const T* F, T bc0, T bcH, T* a, TauWorkspace<T>& ws) {
  tau_solve_flat(f.ref, F, bc0, bcH, a, ws.g.data(), ws.P.data());
}

template <class T>
inline void tau_helmholtz(int n, double lambda, double H, const T* F, T bc0, T bcH, T* a, TauWorkspace<T>& ws) {
  TauFactors f;
  tau_factor(n, lambda, H, f);
  tau_solve(f, F, bc0, bcH, a, ws);
}

}  // namespace capsflow
