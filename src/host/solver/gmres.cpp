// The implementation of gmres.hpp: restarted GMRES(m) for the interface-velocity equation.
#include "host/solver/gmres.hpp"

#include <cmath>
#include <stdexcept>
#include <vector>

namespace capsflow {
namespace {

double dot(std::size_t n, const double* a, const double* b) {
  double s = 0.0;
  for (std::size_t i = 0; i < n; ++i) s += a[i] * b[i];
  return s;
}

}  // namespace

GmresResult gmres(std::size_t n, const std::function<void(const double*, double*)>& apply, const double* b, double* x,
                  const GmresOptions& opt) {
  if (opt.restart < 1 || opt.max_iterations < 1 || !(opt.tolerance > 0.0))
    throw std::invalid_argument("gmres: restart and max_iterations must be >= 1 and tolerance > 0");
  GmresResult res;
  const double bnorm = std::sqrt(dot(n, b, b));
  if (bnorm == 0.0) {
    for (std::size_t i = 0; i < n; ++i) x[i] = 0.0;
    res.converged = true;
    return res;
  }
  const int m = opt.restart;
  std::vector<std::vector<double>> V(static_cast<std::size_t>(m) + 1, std::vector<double>(n));
  std::vector<double> H(static_cast<std::size_t>(m + 1) * m, 0.0), cs(m), sn(m), g(m + 1), y(m), w(n);
  auto h = [&](int i, int j) -> double& { return H[static_cast<std::size_t>(i) * m + j]; };
  for (;;) {
    // r = b - A x
    apply(x, w.data());
    ++res.iterations;
    for (std::size_t i = 0; i < n; ++i) w[i] = b[i] - w[i];
    const double beta = std::sqrt(dot(n, w.data(), w.data()));
    res.residual = beta / bnorm;
    if (res.residual <= opt.tolerance) {
      res.converged = true;
      return res;
    }
    // A non-finite residual (an operator that overflows) cannot recover: stop, not converged, rather than spend the
    // remaining applications on NaN.
    if (res.iterations >= opt.max_iterations || !std::isfinite(res.residual)) return res;
    for (std::size_t i = 0; i < n; ++i) V[0][i] = w[i] / beta;
    std::fill(g.begin(), g.end(), 0.0);
    g[0] = beta;
    int k = 0;  // Krylov vectors used in this cycle
    for (int j = 0; j < m && res.iterations < opt.max_iterations; ++j) {
      apply(V[j].data(), w.data());
      ++res.iterations;
      for (int i = 0; i <= j; ++i) {
        h(i, j) = dot(n, w.data(), V[i].data());
        for (std::size_t t = 0; t < n; ++t) w[t] -= h(i, j) * V[i][t];
      }
      h(j + 1, j) = std::sqrt(dot(n, w.data(), w.data()));
      if (h(j + 1, j) > 0.0)
        for (std::size_t t = 0; t < n; ++t) V[j + 1][t] = w[t] / h(j + 1, j);
      for (int i = 0; i < j; ++i) {  // earlier rotations on the new column
        const double a = h(i, j), c = h(i + 1, j);
        h(i, j) = cs[i] * a + sn[i] * c;
        h(i + 1, j) = -sn[i] * a + cs[i] * c;
      }
      const double d = std::hypot(h(j, j), h(j + 1, j));
      cs[j] = d > 0.0 ? h(j, j) / d : 1.0;
      sn[j] = d > 0.0 ? h(j + 1, j) / d : 0.0;
      h(j, j) = d;
      h(j + 1, j) = 0.0;
      g[j + 1] = -sn[j] * g[j];
      g[j] = cs[j] * g[j];
      k = j + 1;
      res.residual = std::abs(g[j + 1]) / bnorm;
      if (!std::isfinite(res.residual)) return res;  // x as it was at the cycle's start
      if (res.residual <= opt.tolerance || d == 0.0) break;
    }
    // x += V y with H y = g (upper triangular k x k)
    for (int i = k - 1; i >= 0; --i) {
      double s = g[i];
      for (int t = i + 1; t < k; ++t) s -= h(i, t) * y[t];
      y[i] = h(i, i) != 0.0 ? s / h(i, i) : 0.0;
    }
    for (int i = 0; i < k; ++i)
      for (std::size_t t = 0; t < n; ++t) x[t] += y[i] * V[i][t];
    if (res.residual <= opt.tolerance) {
      res.converged = true;
      return res;
    }
    if (res.iterations >= opt.max_iterations) return res;
  }
}

}  // namespace capsflow
