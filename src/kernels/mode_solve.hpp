#pragma once
// Chebyshev-tau building blocks of the per-mode slit Stokes solve (docs/method.md §1.2; docs/method.md).
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

// Lanes: the batched forms below work on L independent real series side by side, value k of lane l at a[k * L + l].
// Complex data of B Fourier modes are 2B real lanes: lane b the real part of mode b, lane B + b its imaginary part.
// For B = 1 that is an array of complex values, as the device kernel holds them; the CPU plan solves 16 modes at
// once, so each recurrence below (a dependency chain per mode) runs as vector operations across modes.

// Coefficients b of du/dy from those of u (degree n), on [0, H]: the standard backward recurrence in s,
// times ds/dy = 2/H.
template <int L>
inline void cheb_derivative_lanes(int n, const double* a, double H, double* b) {
  if (n == 0) {
    for (int l = 0; l < L; ++l) b[l] = 0.0;
    return;
  }
  const double scale = 2.0 / H;
  for (int l = 0; l < L; ++l) {
    b[n * L + l] = 0.0;
    b[(n - 1) * L + l] = (2.0 * n) * a[n * L + l];
  }
  for (int k = n - 1; k >= 1; --k)
    for (int l = 0; l < L; ++l) b[(k - 1) * L + l] = (k + 1 <= n ? b[(k + 1) * L + l] : 0.0) + (2.0 * k) * a[k * L + l];
  for (int l = 0; l < L; ++l) b[l] *= 0.5;
  for (int t = 0; t < (n + 1) * L; ++t) b[t] *= scale;
}

template <class T>
inline void cheb_derivative(int n, const T* a, double H, T* b) {
  static_assert(sizeof(T) % sizeof(double) == 0, "real or complex coefficients");
  constexpr int L = static_cast<int>(sizeof(T) / sizeof(double));
  cheb_derivative_lanes<L>(n, reinterpret_cast<const double*>(a), H, reinterpret_cast<double*>(b));
}

// Solves u'' - lambda u = F on 0 <= y <= H with u(0) = bc0, u(H) = bcH, by the Chebyshev-tau method:
// a (out) and F (in) are Chebyshev coefficients of degree n. The tau equations
//   lam p_k a_{k-2} + (lam q_k - 1) a_k + lam r_k a_{k+2} = -(p_k F_{k-2} + q_k F_k + r_k F_{k+2}),  k = 2..n
// (lam, F scaled by (H/2)^2; p_k = c_{k-2}/(4k(k-1)), q_k = -e_{k+2}/(2(k^2-1)), r_k = e_{k+4}/(4k(k+1)))
// split by parity into two tridiagonal systems closed by one boundary row each; a backward sweep expresses
// every unknown through the first, which the boundary row then fixes. O(n), diagonally dominant for lam >= 0.
//
// The sweep's factors depend on (n, lambda, H) only, not on F or the boundary values: tau_lanes_factor computes
// them once per mode (the CPU plan once per plan) and tau_solve_lanes applies them, so a mode's solves share one
// factorisation. Flat storage, for device code: see tau_lanes_doubles.
inline int tau_stride(int n) { return n / 2 + 2; }

// The factors of B modes. p, q, r depend on n only; den (the reciprocal of the eliminated diagonal) and sumQ on each
// mode's lambda. Row m of parity par: p[par * stride + m], den[(par * stride + m) * B + b]. The sweeps' other
// factors, h_m = -(lambda p_m) den_m and Q_m = h_m Q_{m-1}, are recomputed where they are used (the same products,
// so the same bits), which keeps the plan's cache to one array per mode.
struct TauLanes {
  int n = -1;
  int B = 0;
  int stride = 0;
  double h2 = 0.0;
  int M[2] = {0, 0};  // unknowns per parity
  double *p = nullptr, *q = nullptr, *r = nullptr;
  double* lam = nullptr;   // [b]: lambda (H/2)^2
  double* den = nullptr;   // [(par * stride + m) * B + b]
  double* sumQ = nullptr;  // [par * B + b]: 1 + sum_{m >= 1} Q_m
};

// Doubles of storage for the factors of B modes.
inline std::size_t tau_lanes_doubles(int n, int B) {
  const std::size_t rows = 2 * static_cast<std::size_t>(tau_stride(n));
  return 3 * rows + static_cast<std::size_t>(B) * (rows + 3);
}

inline void tau_lanes_bind(int n, int B, double* storage, TauLanes& f) {
  const std::size_t rows = 2 * static_cast<std::size_t>(tau_stride(n));
  f.n = n;
  f.B = B;
  f.stride = tau_stride(n);
  f.p = storage;
  f.q = f.p + rows;
  f.r = f.q + rows;
  f.lam = f.r + rows;
  f.den = f.lam + B;
  f.sumQ = f.den + rows * B;
}

// Factors for lambda[b], b < f.B (f bound by tau_lanes_bind).
inline void tau_lanes_factor(const double* lambda, double H, TauLanes& f) {
  const int n = f.n, B = f.B, stride = f.stride;
  f.h2 = 0.25 * H * H;
  for (int t = 0; t < 2 * stride; ++t) f.p[t] = f.q[t] = f.r[t] = 0.0;
  for (int t = 0; t < 2 * stride * B; ++t) f.den[t] = 0.0;
  for (int par = 0; par < 2; ++par) {
    const int M = (n - par) / 2 + 1;
    f.M[par] = M;
    double* p = f.p + par * stride;
    double* q = f.q + par * stride;
    double* r = f.r + par * stride;
    for (int m = M - 1; m >= 1; --m) {
      const int k = par + 2 * m;
      const double kk = k;
      p[m] = (k - 2 == 0 ? 2.0 : 1.0) / (4.0 * kk * (kk - 1.0));
      q[m] = -(k + 2 <= n ? 1.0 : 0.0) / (2.0 * (kk * kk - 1.0));
      r[m] = (k + 4 <= n ? 1.0 : 0.0) / (4.0 * kk * (kk + 1.0));
    }
    for (int b = 0; b < B; ++b) {
      const double lam = lambda[b] * f.h2;
      f.lam[b] = lam;
      double* den = f.den + par * stride * B + b;
      double h_next = 0.0;
      for (int m = M - 1; m >= 1; --m) {
        const double lo = lam * p[m], di = lam * q[m] - 1.0, up = lam * r[m];
        // The reciprocal, so the solves' backward sweeps multiply instead of dividing.
        den[m * B] = 1.0 / (di + up * h_next);
        h_next = -lo * den[m * B];
      }
      double Q = 1.0, sumQ = 1.0;
      for (int m = 1; m < M; ++m) {
        Q = (-(lam * p[m]) * den[m * B]) * Q;
        sumQ += Q;
      }
      f.sumQ[par * B + b] = sumQ;
    }
  }
}

// Solves the L = B * P real lanes of F (P = 1 real, 2 complex data; lane pt * B + b uses mode b's factors) with
// boundary values bc0[l], bcH[l] into a. g, w: scratch of tau_stride(n) * L doubles each.
template <int B, int P>
inline void tau_solve_lanes(const TauLanes& f, const double* F, const double* bc0, const double* bcH, double* a,
                            double* g, double* w) {
  constexpr int L = B * P;
  const int n = f.n, stride = f.stride;
  const double h2 = f.h2;
  for (int par = 0; par < 2; ++par) {
    const int M = f.M[par];
    const double* p = f.p + par * stride;
    const double* q = f.q + par * stride;
    const double* r = f.r + par * stride;
    const double* den = f.den + par * stride * B;
    // Backward sweep over the rows m = M-1 .. 1 (k = par + 2m): x_m = g_m + h_m x_{m-1}.
    for (int l = 0; l < L; ++l) g[M * L + l] = 0.0;
    for (int m = M - 1; m >= 1; --m) {
      const int k = par + 2 * m;
      const double pm = p[m], qm = q[m], rm = r[m];
      const double* Fm = F + (k - 2) * L;
      const double* F0 = F + k * L;
      for (int pt = 0; pt < P; ++pt)
        for (int b = 0; b < B; ++b) {
          const int l = pt * B + b;
          const double Fp = k + 2 <= n ? F[(k + 2) * L + l] * h2 : 0.0;
          const double rhs = -(pm * (Fm[l] * h2) + qm * (F0[l] * h2) + rm * Fp);
          g[m * L + l] = (rhs - (f.lam[b] * rm) * g[(m + 1) * L + l]) * den[m * B + b];
        }
    }
    // Forward: x_m = P_m + Q_m x_0; the boundary row sum_m x_m = bc fixes x_0.
    double sumP[L], x0[L], Q[B];
    for (int l = 0; l < L; ++l) {
      w[l] = 0.0;
      sumP[l] = 0.0;
    }
    for (int m = 1; m < M; ++m) {
      const double pm = p[m];
      for (int pt = 0; pt < P; ++pt)
        for (int b = 0; b < B; ++b) {
          const int l = pt * B + b;
          const double hm = -(f.lam[b] * pm) * den[m * B + b];
          w[m * L + l] = g[m * L + l] + hm * w[(m - 1) * L + l];
          sumP[l] += w[m * L + l];
        }
    }
    for (int pt = 0; pt < P; ++pt)
      for (int b = 0; b < B; ++b) {
        const int l = pt * B + b;
        const double bc = par == 0 ? 0.5 * (bcH[l] + bc0[l]) : 0.5 * (bcH[l] - bc0[l]);
        x0[l] = (bc - sumP[l]) / f.sumQ[par * B + b];
      }
    for (int b = 0; b < B; ++b) Q[b] = 1.0;
    for (int m = 0; m < M; ++m) {
      if (m > 0)
        for (int b = 0; b < B; ++b) Q[b] = (-(f.lam[b] * p[m]) * den[m * B + b]) * Q[b];
      for (int pt = 0; pt < P; ++pt)
        for (int b = 0; b < B; ++b) {
          const int l = pt * B + b;
          a[(par + 2 * m) * L + l] = w[m * L + l] + Q[b] * x0[l];
        }
    }
  }
}

// The inputs of B Fourier modes of the slit solve (per mode b unless said): kx, kz the factors of the first
// derivatives (0 for an unpaired Nyquist direction, docs/method.md §1.2); mean 1 for the k = 0 mode; the wall values
// as 2B real lanes; phi_1, psi_1 at [k * B + b] and the inverse influence matrix at [e * B + b] (zero for the
// mean mode).
struct ModeLanes {
  const double* kx = nullptr;
  const double* kz = nullptr;
  const int* mean = nullptr;
  const double *ub0 = nullptr, *ubH = nullptr, *vb0 = nullptr, *vbH = nullptr, *wb0 = nullptr, *wbH = nullptr;
  const double *phi = nullptr, *psi = nullptr, *minv = nullptr;
};

// ModeLanes of B modes whose wall values lie one after another, 2B lanes each, in the order u(0), u(H), v(0), v(H),
// w(0), w(H).
inline ModeLanes mode_lanes(int B, const double* kx, const double* kz, const int* mean, const double* walls,
                            const double* phi, const double* psi, const double* minv) {
  ModeLanes in;
  in.kx = kx;
  in.kz = kz;
  in.mean = mean;
  in.ub0 = walls;
  in.ubH = walls + 2 * B;
  in.vb0 = walls + 4 * B;
  in.vbH = walls + 6 * B;
  in.wb0 = walls + 8 * B;
  in.wbH = walls + 10 * B;
  in.phi = phi;
  in.psi = psi;
  in.minv = minv;
  return in;
}

// Scratch doubles of slit_modes_velocity for B modes.
inline std::size_t slit_modes_work_doubles(int N, int B) {
  return 2 * static_cast<std::size_t>(B) * (7 * static_cast<std::size_t>(N + 1) + 2 * tau_stride(N));
}

// B Fourier modes of the slit solve between the two Chebyshev transforms (docs/method.md §1.2), for the CPU plan
// (B = 16) and the device kernel (B = 1, one mode per thread) alike. In: rx, ry, rz the Chebyshev coefficients of
// rho/mu (2B lanes each); fac the factors of each mode's k^2 (0 for the mean mode). Out: rx, ry, rz the
// velocity's coefficients. work: slit_modes_work_doubles(N, B).
template <int B>
inline void slit_modes_velocity(int N, double H, const ModeLanes& in, const TauLanes& fac, double* rx, double* ry,
                                double* rz, double* work) {
  constexpr int L = 2 * B;
  const int np = N + 1;
  double* dry = work;
  double* rhs = dry + np * L;
  double* p = rhs + np * L;
  double* dp = p + np * L;
  double* dv = dp + np * L;
  double* mx = dv + np * L;
  double* mz = mx + np * L;
  double* g = mz + np * L;
  double* w = g + tau_stride(N) * L;
  bool any_mean = false, all_mean = true;
  for (int b = 0; b < B; ++b) {
    any_mean = any_mean || in.mean[b] != 0;
    all_mean = all_mean && in.mean[b] != 0;
  }
  if (any_mean) {
    // Mean mode (6.6): u0'' = -rho_x0/mu, w0'' = -rho_z0/mu (its factors have lambda = 0), v0 = mean of its wall
    // values. Solved for every lane of the batch; only the mean lanes keep it.
    for (int t = 0; t < np * L; ++t) rhs[t] = -rx[t];
    tau_solve_lanes<B, 2>(fac, rhs, in.ub0, in.ubH, mx, g, w);
    for (int t = 0; t < np * L; ++t) rhs[t] = -rz[t];
    tau_solve_lanes<B, 2>(fac, rhs, in.wb0, in.wbH, mz, g, w);
  }
  if (!all_mean) {
    const double zero[L] = {};
    const double* kx = in.kx;
    const double* kz = in.kz;
    // Particular solution: pressure with p = 0 on the walls, then the three velocity components (the solution
    // overwrites the forcing columns: u -> rx, v -> ry, w -> rz; dry is consumed first). i k times a complex lane
    // pair: (re, im) -> (-k im, k re).
    cheb_derivative_lanes<L>(N, ry, H, dry);
    for (int k = 0; k <= N; ++k)
      for (int b = 0; b < B; ++b) {
        const int re = k * L + b, im = re + B;
        rhs[re] = (-kx[b] * rx[im] + dry[re]) + (-kz[b] * rz[im]);
        rhs[im] = (kx[b] * rx[re] + dry[im]) + kz[b] * rz[re];
      }
    tau_solve_lanes<B, 2>(fac, rhs, zero, zero, p, g, w);
    cheb_derivative_lanes<L>(N, p, H, dp);
    for (int t = 0; t < np * L; ++t) rhs[t] = dp[t] - ry[t];
    tau_solve_lanes<B, 2>(fac, rhs, in.vb0, in.vbH, ry, g, w);
    for (int k = 0; k <= N; ++k)
      for (int b = 0; b < B; ++b) {
        const int re = k * L + b, im = re + B;
        rhs[re] = -kx[b] * p[im] - rx[re];
        rhs[im] = kx[b] * p[re] - rx[im];
      }
    tau_solve_lanes<B, 2>(fac, rhs, in.ub0, in.ubH, rx, g, w);
    for (int k = 0; k <= N; ++k)
      for (int b = 0; b < B; ++b) {
        const int re = k * L + b, im = re + B;
        rhs[re] = -kz[b] * p[im] - rz[re];
        rhs[im] = kz[b] * p[re] - rz[im];
      }
    tau_solve_lanes<B, 2>(fac, rhs, in.wb0, in.wbH, rz, g, w);
    cheb_derivative_lanes<L>(N, ry, H, dv);
    // Wall divergences of the particular solution, then the influence matrix: add c1 H1 + c2 H2 so that
    // div u = 0 on both walls.
    double dv0[L], dvH[L], c1[L], c2[L];
    for (int l = 0; l < L; ++l) dv0[l] = dvH[l] = 0.0;
    for (int k = 0; k <= N; ++k)
      for (int l = 0; l < L; ++l) {
        dvH[l] += dv[k * L + l];
        dv0[l] += (k % 2 ? -dv[k * L + l] : dv[k * L + l]);
      }
    for (int b = 0; b < B; ++b) {
      const int re = b, im = B + b;
      const double th0r = (-kx[b] * in.ub0[im] + dv0[re]) + (-kz[b] * in.wb0[im]);
      const double th0i = (kx[b] * in.ub0[re] + dv0[im]) + kz[b] * in.wb0[re];
      const double thHr = (-kx[b] * in.ubH[im] + dvH[re]) + (-kz[b] * in.wbH[im]);
      const double thHi = (kx[b] * in.ubH[re] + dvH[im]) + kz[b] * in.wbH[re];
      const double m0 = in.minv[0 * B + b], m1 = in.minv[1 * B + b], m2 = in.minv[2 * B + b], m3 = in.minv[3 * B + b];
      c1[re] = -(m0 * th0r + m1 * thHr);
      c1[im] = -(m0 * th0i + m1 * thHi);
      c2[re] = -(m2 * th0r + m3 * thHr);
      c2[im] = -(m2 * th0i + m3 * thHi);
    }
    for (int k = 0; k <= N; ++k) {
      const double sgn = (k % 2) ? -1.0 : 1.0;  // phi_2 = phi_1 reflected, psi_2 = -psi_1 reflected
      for (int b = 0; b < B; ++b) {
        const int re = k * L + b, im = re + B;
        const double ph = in.phi[k * B + b], ps = in.psi[k * B + b];
        const double phr = c1[b] * ph + c2[b] * (sgn * ph), phi_ = c1[B + b] * ph + c2[B + b] * (sgn * ph);
        const double psr = c1[b] * ps - c2[b] * (sgn * ps), psi_ = c1[B + b] * ps - c2[B + b] * (sgn * ps);
        rx[re] += -kx[b] * phi_;
        rx[im] += kx[b] * phr;
        ry[re] += psr;
        ry[im] += psi_;
        rz[re] += -kz[b] * phi_;
        rz[im] += kz[b] * phr;
      }
    }
  }
  if (any_mean)
    for (int b = 0; b < B; ++b) {
      if (!in.mean[b]) continue;
      for (int k = 0; k <= N; ++k)
        for (int pt = 0; pt < 2; ++pt) {
          const int l = k * L + pt * B + b;
          rx[l] = mx[l];
          rz[l] = mz[l];
          ry[l] = k == 0 ? 0.5 * (in.vb0[pt * B + b] + in.vbH[pt * B + b]) : 0.0;
        }
    }
}
CAPSFLOW_DEVICE_END

// The host form for one real solve (the homogeneous solutions, the tests): owns its arrays.
struct TauWorkspace {
  std::vector<double> fac, g, w;
  TauLanes f;
  explicit TauWorkspace(int n = 0) { resize(n); }
  void resize(int n) {
    fac.assign(tau_lanes_doubles(n, 1), 0.0);
    g.assign(static_cast<std::size_t>(tau_stride(n)), 0.0);
    w.assign(static_cast<std::size_t>(tau_stride(n)), 0.0);
    tau_lanes_bind(n, 1, fac.data(), f);
  }
};

inline void tau_helmholtz(int n, double lambda, double H, const double* F, double bc0, double bcH, double* a,
                          TauWorkspace& ws) {
  if (ws.f.n != n) ws.resize(n);
  tau_lanes_factor(&lambda, H, ws.f);
  tau_solve_lanes<1, 1>(ws.f, F, &bc0, &bcH, a, ws.g.data(), ws.w.data());
}

}  // namespace capsflow
