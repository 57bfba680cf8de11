// Exact Green's function of Stokes flow in a doubly periodic slit (see slit_green_reference.hpp).
//
// Derivation (summary).
//   mu lap u - grad p + F delta(x - x0) = 0, div u = 0, u = 0 at y = 0, H; u, p periodic in x, z.
// Fourier series in rho = (x, z), k = 2 pi (nx/Lx, nz/Lz), A = Lx Lz:
//   u(rho, y) = (1/A) sum_k exp(i k.(rho - rho0)) uhat_k(y).
// Rotate the wall-parallel components into e_par = k/|k| and e_perp = (-kz, kx)/|k| (and y):
//   mu (D^2 - k^2) u_par  - i k p + F_par  delta(y - y0) = 0
//   mu (D^2 - k^2) v      - D p   + F_y    delta(y - y0) = 0
//   mu (D^2 - k^2) u_perp         + F_perp delta(y - y0) = 0
//   i k u_par + D v = 0                                   (D = d/dy, k = |k| > 0)
// so u_perp decouples (a scalar 1D Helmholtz problem) and (u_par, v) is a 2D Stokes problem.
//
// Free-space mode (Y = y - y0): the 3D transform of the Oseen tensor (I + rr/r^2)/(8 pi mu r) is
// (I - qq/q^2)/(mu q^2); integrating over q_y with
//   I0 = int dq/(2pi) e^{iqY}/(q^2+k^2)   = e^{-k|Y|}/(2k),
//   I1 = int dq/(2pi) e^{iqY}/(q^2+k^2)^2 = (1 + k|Y|) e^{-k|Y|}/(4k^3)   (= -dI0/d(k^2)),
// gives, with q = (k, q_y, 0) in the (par, y, perp) frame and E = e^{-k|Y|}:
//   G_par,par = I0 - k^2 I1 = (1 - k|Y|) E/(4k mu),   G_yy = k^2 I1 = (1 + k|Y|) E/(4k mu),
//   G_par,y = G_y,par = i k dI1/dY = -i Y E/(4 mu),    G_perp,perp = I0/mu = E/(2k mu).
// (Checked: i k u_par + D v = 0 for both force directions.)
//
// Homogeneous correction. Write W = i v; continuity gives u_par = D W / k, and any W with
// (D^2 - k^2)^2 W = 0 is a Stokes solution (the pressure follows from the par equation). With
// t = H - y and scaled coefficients (a, b, c, d):
//   W_h = (a + b k y) e^{-k y} + (c + d k t) e^{-k t}
//   U_h = D W_h / k = (b - a - b k y) e^{-k y} + (c - d + d k t) e^{-k t}
// (only decaying exponentials: no overflow for large kH). W_h = -W_free, U_h = -U_free at y = 0
// and y = H is a real 4x4 system, solved per mode by Gaussian elimination with partial pivoting.
// Two real problems: F_par (W_free = Y E/4, U_free = (1 - k|Y|) E/(4k)) and F_y (W = i W2 with
// W2_free = (1 + k|Y|) E/(4k), u_par = i D W2/k, D W2_free/k = -Y E/4). Collecting:
//   uhat_par = alpha1 F_par - i alpha2 F_y,  vhat = -i beta1 F_par + beta2 F_y,  uhat_perp = gamma F_perp
// with alpha1 = U1, beta1 = W1, alpha2 = -U2, beta2 = W2 (totals, free + homogeneous).
// Perpendicular problem in closed form (Dirichlet Green's function of D^2 - k^2):
//   gamma = sinh(k y<) sinh(k (H - y>)) / (k mu sinh kH)
//         = E (1 - e^{-2 k y<}) (1 - e^{-2 k (H - y>)}) / (2 k mu (1 - e^{-2kH})).
// Real-space sum: pairing k and -k (e_par changes sign, the coefficients depend on |k| only),
//   u_inplane = (1/A) sum_k [cos(k.drho) (alpha1 e_par e_par + gamma e_perp e_perp) F_in + sin(k.drho) alpha2 e_par F_y]
//   v         = (1/A) sum_k [cos(k.drho) beta2 F_y + sin(k.drho) beta1 e_par.F_in]
// k = 0 mode: mu D^2 u_in = -F_in delta(y - y0), u_in = 0 on the walls -> u_in = F_in y< (H - y>)/(mu H);
// v: D v = 0 and v = 0 on the walls -> v = 0 (the pressure carries F_y). Divided by A this is the
// plane-averaged flow of docs/validation.md, VD 5.
//
// Truncation: sum over |k| <= K. Per mode, |free entries| <= (1 + k d) e^{-k d}/(2 k mu) with d = |Y|,
// and the homogeneous entries behave like (1 + k dw + (k dw)^2) e^{-k dw}/(k mu) with
// dw = min(y + y0, 2H - y - y0) >= d. With (A/2pi) k dk lattice points per shell (shifted by one cell
// diagonal for the lattice discreteness) the tail is at most
//   (1/(2 pi mu)) [ (2 + s) e^{-s}/d + (4 + 3 sw + sw^2) e^{-sw}/dw ],  s = K' d, sw = K' dw,
// K' = K - |cell diagonal|. K is the smallest value making (safety x tail) <= tol/(8 pi mu r).
// For d -> 0 (target in the source plane) the free-space part converges only algebraically: the
// required K exceeds the mode cap and std::domain_error is thrown. The wall part has no d term.
#include "support/slit_green_reference.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace capsflow::test {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kSafety = 10.0;

struct ModeCoef {
  double a1, a2, b1, b2, g;
};

// Solve the 4x4 system M x = r for two right-hand sides (partial pivoting).
void solve4(double M[4][4], double r1[4], double r2[4]) {
  for (int c = 0; c < 4; ++c) {
    int p = c;
    for (int i = c + 1; i < 4; ++i)
      if (std::abs(M[i][c]) > std::abs(M[p][c])) p = i;
    if (p != c) {
      for (int j = 0; j < 4; ++j) std::swap(M[c][j], M[p][j]);
      std::swap(r1[c], r1[p]);
      std::swap(r2[c], r2[p]);
    }
    for (int i = c + 1; i < 4; ++i) {
      const double f = M[i][c] / M[c][c];
      if (f == 0.0) continue;
      for (int j = c; j < 4; ++j) M[i][j] -= f * M[c][j];
      r1[i] -= f * r1[c];
      r2[i] -= f * r2[c];
    }
  }
  for (int c = 3; c >= 0; --c) {
    for (int j = c + 1; j < 4; ++j) {
      r1[c] -= M[c][j] * r1[j];
      r2[c] -= M[c][j] * r2[j];
    }
    r1[c] /= M[c][c];
    r2[c] /= M[c][c];
  }
}

// Mode coefficients (times mu) for |k| = k at target height y, source height y0.
ModeCoef mode_coef(double k, double y, double y0, double H, bool wall_only) {
  // Free-space profiles as functions of Y: P = W1_free, R = U1_free, Q = W2_free, S = -U2_free.
  auto P = [k](double Y) { return 0.25 * Y * std::exp(-k * std::abs(Y)); };
  auto R = [k](double Y) { return (1.0 - k * std::abs(Y)) * std::exp(-k * std::abs(Y)) / (4.0 * k); };
  auto Q = [k](double Y) { return (1.0 + k * std::abs(Y)) * std::exp(-k * std::abs(Y)) / (4.0 * k); };
  const double kH = k * H, E = std::exp(-kH);
  // Rows: W_h(0), W_h(H), U_h(0), U_h(H); unknowns (a, b, c, d) as in the header comment.
  double M[4][4] = {{1.0, 0.0, E, kH * E},
                    {E, kH * E, 1.0, 0.0},
                    {-1.0, 1.0, E, (kH - 1.0) * E},
                    {-E, (1.0 - kH) * E, 1.0, -1.0}};
  const double Yb = -y0, Yt = H - y0;  // free-space Y at the bottom and top walls
  double r1[4] = {-P(Yb), -P(Yt), -R(Yb), -R(Yt)};
  double r2[4] = {-Q(Yb), -Q(Yt), P(Yb), P(Yt)};  // U2_free = -S = -P
  solve4(M, r1, r2);
  const double t = H - y, ey = std::exp(-k * y), et = std::exp(-k * t);
  auto Wh = [&](const double* x) { return (x[0] + x[1] * k * y) * ey + (x[2] + x[3] * k * t) * et; };
  auto Uh = [&](const double* x) { return (x[1] - x[0] - x[1] * k * y) * ey + (x[2] - x[3] + x[3] * k * t) * et; };
  ModeCoef m{};
  const double Y = y - y0;
  const double ylo = std::min(y, y0), yhi = std::max(y, y0);
  const double e2a = std::exp(-2.0 * k * ylo), e2b = std::exp(-2.0 * k * (H - yhi));
  const double den = -std::expm1(-2.0 * kH);
  const double eY = std::exp(-k * std::abs(Y)) / (2.0 * k);
  if (wall_only) {
    m.a1 = Uh(r1);
    m.b1 = Wh(r1);
    m.a2 = -Uh(r2);
    m.b2 = Wh(r2);
    m.g = eY * (std::exp(-2.0 * kH) - e2a - e2b + e2a * e2b) / den;
  } else {
    m.a1 = R(Y) + Uh(r1);
    m.b1 = P(Y) + Wh(r1);
    m.a2 = P(Y) - Uh(r2);
    m.b2 = Q(Y) + Wh(r2);
    m.g = eY * (1.0 - e2a) * (1.0 - e2b) / den;
  }
  return m;
}

// Wrap into [-L/2, L/2).
double min_image(double dx, double L) { return dx - L * std::floor(dx / L + 0.5); }

void check_args(const SlitRefGeometry& g, const double src[3], const double tgt[3], double tol) {
  if (!(g.H > 0 && g.Lx > 0 && g.Lz > 0 && g.mu > 0)) throw std::invalid_argument("slit reference: bad geometry");
  if (!(src[1] > 0 && src[1] < g.H)) throw std::invalid_argument("slit reference: source must satisfy 0 < y0 < H");
  if (!(tgt[1] >= 0 && tgt[1] <= g.H)) throw std::invalid_argument("slit reference: target must satisfy 0 <= y <= H");
  if (!(tol > 0)) throw std::invalid_argument("slit reference: tol must be positive");
}

std::string fmt(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

struct Plan {
  double K;
  std::size_t modes;
};

// Choose the cutoff K from the tail bound (header comment). d <= 0 means "no free-space part".
Plan plan_cutoff(const SlitRefGeometry& g, double d, double dw, double r, double tol, std::size_t max_modes,
                 bool wall_only) {
  const double A = g.Lx * g.Lz;
  const double cell = std::hypot(2.0 * kPi / g.Lx, 2.0 * kPi / g.Lz);
  auto tail = [&](double K) {
    const double Ke = std::max(K - cell, 0.0);
    double tsum = 0.0;
    if (!wall_only) {
      const double s = Ke * d;
      tsum += (2.0 + s) * std::exp(-s) / d;
    }
    const double sw = Ke * dw;
    tsum += (4.0 + 3.0 * sw + sw * sw) * std::exp(-sw) / dw;
    return kSafety * 4.0 * r * tsum;  // (safety * tail) / (1/(8 pi mu r)), mu cancels
  };
  auto modes_of = [&](double K) { return K * K * A / (4.0 * kPi) + 4.0 * K * (g.Lx + g.Lz) / (2.0 * kPi) + 4.0; };
  const double dmin = wall_only ? dw : d;
  if (!(dmin > 0)) {
    throw std::domain_error(
        "slit reference: target in the source plane (y == y0); the Fourier series of the full Green's "
        "function does not converge exponentially there (use the wall part)");
  }
  double hi = cell + 1.0 / dmin;
  while (tail(hi) > tol && modes_of(hi) <= 4.0 * static_cast<double>(max_modes)) hi *= 2.0;
  if (tail(hi) > tol) {
    throw std::domain_error("slit reference: tolerance " + fmt(tol) +
                            " needs more than max_modes Fourier modes (target too close to the source plane: "
                            "|y - y0| = " + fmt(d) + ")");
  }
  double lo = 0.0;
  for (int it = 0; it < 60; ++it) {
    const double mid = 0.5 * (lo + hi);
    if (tail(mid) > tol)
      lo = mid;
    else
      hi = mid;
  }
  const double est = modes_of(hi);
  if (est > static_cast<double>(max_modes)) {
    throw std::domain_error("slit reference: tolerance " + fmt(tol) + " needs about " + fmt(est) +
                            " Fourier modes, more than max_modes = " + fmt(static_cast<double>(max_modes)) +
                            " (target too close to the source plane: |y - y0| = " + fmt(d) + ")");
  }
  return Plan{hi, static_cast<std::size_t>(est)};
}

struct Setup {
  double dx, dz, d, dw, r;
};

Setup setup(const SlitRefGeometry& g, const double src[3], const double tgt[3], bool wall_only) {
  Setup s{};
  s.dx = min_image(tgt[0] - src[0], g.Lx);
  s.dz = min_image(tgt[2] - src[2], g.Lz);
  s.d = std::abs(tgt[1] - src[1]);
  s.dw = std::min(tgt[1] + src[1], 2.0 * g.H - tgt[1] - src[1]);
  const double rho2 = s.dx * s.dx + s.dz * s.dz;
  s.r = std::sqrt(rho2 + (wall_only ? s.dw * s.dw : s.d * s.d));
  return s;
}

void tensor_impl(const SlitRefGeometry& g, const double src[3], const double tgt[3], double G[3][3], double tol,
                 std::size_t max_modes, bool wall_only) {
  check_args(g, src, tgt, tol);
  const Setup s = setup(g, src, tgt, wall_only);
  const Plan plan = plan_cutoff(g, s.d, s.dw, s.r, tol, max_modes, wall_only);
  const double K = plan.K;
  const double y = tgt[1], y0 = src[1], H = g.H;
  const double dkx = 2.0 * kPi / g.Lx, dkz = 2.0 * kPi / g.Lz;
  const int Nx = static_cast<int>(std::floor(K / dkx)), Nz = static_cast<int>(std::floor(K / dkz));
  std::vector<double> cx(Nx + 1), sx(Nx + 1), cz(Nz + 1), sz(Nz + 1);
  for (int n = 0; n <= Nx; ++n) {
    cx[n] = std::cos(n * dkx * s.dx);
    sx[n] = std::sin(n * dkx * s.dx);
  }
  for (int n = 0; n <= Nz; ++n) {
    cz[n] = std::cos(n * dkz * s.dz);
    sz[n] = std::sin(n * dkz * s.dz);
  }
  // Accumulators (Kahan-free; terms decay fast): Gxx, Gxz, Gzz, Gxy, Gzy, Gyx, Gyz, Gyy.
  double axx = 0, axz = 0, azz = 0, axy = 0, azy = 0, ayx = 0, ayz = 0, ayy = 0;
  for (int nx = 0; nx <= Nx; ++nx) {
    const double kx = nx * dkx;
    for (int nz = 0; nz <= Nz; ++nz) {
      if (nx == 0 && nz == 0) continue;
      const double kz = nz * dkz;
      const double k = std::hypot(kx, kz);
      if (k > K) break;
      const ModeCoef m = mode_coef(k, y, y0, H, wall_only);
      const int nsx = nx == 0 ? 1 : 2, nsz = nz == 0 ? 1 : 2;
      for (int ix = 0; ix < nsx; ++ix) {
        const double sgx = ix == 0 ? 1.0 : -1.0;
        for (int iz = 0; iz < nsz; ++iz) {
          const double sgz = iz == 0 ? 1.0 : -1.0;
          // theta = sgx kx dx + sgz kz dz
          const double c = cx[nx] * cz[nz] - sgx * sgz * sx[nx] * sz[nz];
          const double sn = sgx * sx[nx] * cz[nz] + sgz * cx[nx] * sz[nz];
          const double ex = sgx * kx / k, ez = sgz * kz / k;  // e_par; e_perp = (-ez, ex)
          axx += c * (m.a1 * ex * ex + m.g * ez * ez);
          axz += c * (m.a1 - m.g) * ex * ez;
          azz += c * (m.a1 * ez * ez + m.g * ex * ex);
          axy += sn * m.a2 * ex;
          azy += sn * m.a2 * ez;
          ayx += sn * m.b1 * ex;
          ayz += sn * m.b1 * ez;
          ayy += c * m.b2;
        }
      }
    }
  }
  const double A = g.Lx * g.Lz, s0 = 1.0 / (g.mu * A);
  const double mean = std::min(y, y0) * (H - std::max(y, y0)) / H;  // k = 0 mode (times mu A)
  G[0][0] = s0 * (axx + mean);
  G[0][1] = s0 * axy;
  G[0][2] = s0 * axz;
  G[1][0] = s0 * ayx;
  G[1][1] = s0 * ayy;
  G[1][2] = s0 * ayz;
  G[2][0] = s0 * axz;
  G[2][1] = s0 * azy;
  G[2][2] = s0 * (azz + mean);
}

void apply(const double G[3][3], const double F[3], double u[3]) {
  for (int i = 0; i < 3; ++i) u[i] = G[i][0] * F[0] + G[i][1] * F[1] + G[i][2] * F[2];
}

}  // namespace

void slit_green_tensor(const SlitRefGeometry& g, const double src[3], const double tgt[3], double G[3][3], double tol,
                       std::size_t max_modes) {
  tensor_impl(g, src, tgt, G, tol, max_modes, false);
}

void slit_green_wall_tensor(const SlitRefGeometry& g, const double src[3], const double tgt[3], double G[3][3],
                            double tol, std::size_t max_modes) {
  tensor_impl(g, src, tgt, G, tol, max_modes, true);
}

void slit_green_velocity(const SlitRefGeometry& g, const double src[3], const double F[3], const double tgt[3],
                         double u[3], double tol, std::size_t max_modes) {
  double G[3][3];
  tensor_impl(g, src, tgt, G, tol, max_modes, false);
  apply(G, F, u);
}

void slit_green_wall_velocity(const SlitRefGeometry& g, const double src[3], const double F[3], const double tgt[3],
                              double u[3], double tol, std::size_t max_modes) {
  double G[3][3];
  tensor_impl(g, src, tgt, G, tol, max_modes, true);
  apply(G, F, u);
}

std::size_t slit_green_mode_count(const SlitRefGeometry& g, const double src[3], const double tgt[3], double tol,
                                  bool wall_only, std::size_t max_modes) {
  check_args(g, src, tgt, tol);
  const Setup s = setup(g, src, tgt, wall_only);
  return plan_cutoff(g, s.d, s.dw, s.r, tol, max_modes, wall_only).modes;
}

}  // namespace capsflow::test
