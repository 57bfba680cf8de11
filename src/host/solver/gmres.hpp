#pragma once
// Restarted GMRES(m) (Saad & Schultz 1986) for the interface-velocity equation of a viscosity ratio other than 1
// (docs/method.md "Viscosity ratio"): Arnoldi with modified Gram-Schmidt, Givens rotations, the residual estimate
// |g_{j+1}| as the stopping test. Plain vectors; the operator is a callback, so the solver knows nothing of GGEM.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <functional>

namespace capsflow {

struct GmresOptions {
  double tolerance = 1e-6;  // stop when |b - A x| <= tolerance |b| (the Arnoldi estimate)
  int restart = 30;         // Krylov vectors per cycle (memory: restart + 1 vectors of the problem size)
  int max_iterations = 200;  // operator applications in all cycles
};

struct GmresResult {
  int iterations = 0;      // operator applications (the initial residual's included)
  double residual = 0.0;   // final relative residual |b - A x| / |b| (the estimate; 0 when b = 0)
  bool converged = false;
};

// Solves summed over steps: how many, operator applications in all, the largest count and the largest final
// residual. One way to add a solve, for every tally of solves (the run's summary; Simulation's per-record figures).
struct GmresTally {
  std::int64_t steps = 0, iterations = 0, max_iterations = 0;
  double max_residual = 0.0;
  void add(const GmresResult& r) {
    ++steps;
    iterations += r.iterations;
    max_iterations = std::max<std::int64_t>(max_iterations, r.iterations);
    max_residual = std::max(max_residual, r.residual);
  }
};

// Solves A x = b for n unknowns; x holds the first guess on entry. apply(in, out): out = A in (both n long).
GmresResult gmres(std::size_t n, const std::function<void(const double*, double*)>& apply, const double* b, double* x,
                  const GmresOptions& opt);

}  // namespace capsflow
