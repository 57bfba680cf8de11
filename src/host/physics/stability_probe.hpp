#pragma once
// Stability probe of the explicit membrane step (docs/method.md section 4.1): measures, rather than guesses, the
// largest step that AB2 can take in a given configuration.
//
// The node motion is dx/dt = u(x), u the projected node velocity (membrane forces -> boundary integral -> volume-rate
// projection). Linearised about the current state, a perturbation obeys d(dx)/dt = J dx, J = du/dx. AB2 with step
// tau is stable for an eigenvalue lambda of J when both roots of z^2 - (1 + 3/2 lambda tau) z + 1/2 lambda tau have
// |z| <= 1; on the negative real axis that is lambda tau >= -1.
//
// J is never formed: its product with a vector is a finite difference, J v ~ (u(x + eps v) - u(x)) / eps (one
// velocity evaluation each). The extreme eigenvalues come from an Arnoldi process on these products (m of them):
// the Ritz values of the m x m Hessenberg matrix. Arnoldi is power iteration that keeps its whole history, so the
// same number of evaluations gives the extreme eigenvalue far more accurately when the top of the spectrum is
// clustered, as it is for a membrane (many element-scale modes of nearly equal rate).
//
// Reported in the units of the step rule (strain units, lengths in a): c = |lambda| Ca_ref h with h the shortest
// edge, and cfl_crit, the largest cfl of dt = cfl Ca_ref h for which every converged Ritz value of the top of the
// spectrum is inside AB2's stability region (1/c for a negative real lambda).
//
// Usage:
//     Simulation sim(cfg);              // host backend; bring it to the state to probe (advance() ...)
//     StabilityEstimate e = probe_stability(sim, {});
//     std::printf("c = %g, cfl_crit = %g\n", e.c, e.cfl_crit);
#include <cstdint>
#include <vector>

#include "host/physics/simulation.hpp"

namespace capsflow {

struct StabilityProbeOptions {
  int iterations = 40;            // Arnoldi steps (velocity evaluations after the first)
  double rms_displacement = 1e-7; // finite-difference step: rms node displacement of eps v (units of a)
  std::uint64_t seed = 1;         // the random start vector
};

struct StabilityEstimate {
  double lambda_re = 0.0, lambda_im = 0.0;  // Ritz value of largest modulus (1 / strain unit)
  double lambda_abs = 0.0;                  // its modulus
  double ritz_residual = 0.0;               // |h_(m+1,m) e_m^T y| / |lambda|: how converged that value is
  double h = 0.0;                           // shortest edge of the state
  double ca = 0.0;                          // Ca of the step rule
  double c = 0.0;                           // lambda_abs * ca * h
  double cfl_crit = 0.0;                    // largest stable cfl over the top Ritz values (AB2)
  int evaluations = 0;                      // velocity evaluations used
  // The finite-difference step the numbers above were measured with (rms node displacement, units of a), and the
  // growing top Ritz value a first measurement at StabilityProbeOptions::rms_displacement found, when it did (0
  // otherwise): see probe_stability.
  double rms_displacement = 0.0;
  double discarded_growth = 0.0;
};

// A top Ritz value that grows (Re lambda > 0: no membrane relaxation mode does) is a finite-difference artefact
// where a node sits on a switch of the interpolation stencil (the nearest Chebyshev plane changes half-way between
// planes: at mid-channel when the degree is odd, where a mid-channel capsule of the icosphere has nodes exactly):
// the velocity jumps there by the interpolation's error, and the jump over a 1e-7 step reads as a rate of ~30 per
// strain unit (H 5, alpha 4: degree 63). The probe then measures again with a step 100 times larger, where the
// jump's share is 100 times smaller, and keeps that measurement (rms_displacement and discarded_growth say so).
StabilityEstimate probe_stability(Simulation& sim, const StabilityProbeOptions& opt);

// Largest tau >= 0 (up to tau_max) such that AB2 is stable for lambda tau at every smaller tau as well (bisection on
// the root moduli). lambda in any units; tau in the inverse units.
double ab2_stable_step(double lambda_re, double lambda_im, double tau_max);

// Growth of a small perturbation under fixed steps: runs `reference` and a copy perturbed by random node
// displacements of rms `amplitude` (the same seed -> the same displacements), both with advance_fixed(dt), for
// `steps` steps or until the growth exceeds `stop_growth`. Growth = rms of the difference of the node positions
// relative to each capsule's centroid (a rigid shift of a capsule, neutral in shear, is not an instability) over the
// initial one. Both simulations are consumed.
struct GrowthResult {
  double growth = 0.0;  // final rms difference / initial
  int steps = 0;        // steps taken
  bool blew_up = false; // a stop reason (non-finite, left the slit, mesh too large) ended either run
};
GrowthResult perturbation_growth(Simulation& reference, Simulation& perturbed, double dt, int steps,
                                 double amplitude, std::uint64_t seed, double stop_growth);

}  // namespace capsflow
