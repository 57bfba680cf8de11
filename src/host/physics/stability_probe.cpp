// The implementation of stability_probe.hpp: the probe that measures the largest stable AB2 step.
#include "host/physics/stability_probe.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <complex>
#include <random>
#include <stdexcept>

#include "kernels/capsule_geometry.hpp"

namespace capsflow {

namespace {

// Largest root modulus of AB2's characteristic polynomial z^2 - (1 + 3/2 q) z + 1/2 q, q = lambda tau.
double ab2_root_modulus(std::complex<double> q) {
  const std::complex<double> b = -(1.0 + 1.5 * q), c = 0.5 * q;
  const std::complex<double> d = std::sqrt(b * b - 4.0 * c);
  return std::max(std::abs((-b + d) / 2.0), std::abs((-b - d) / 2.0));
}

// Node positions relative to each capsule's node mean (rigid translations removed), interleaved.
std::vector<double> shape_coordinates(const Simulation& sim) {
  const CapsuleState& s = sim.state();
  const int nc = s.num_capsules(), nv = s.nodes_per_capsule();
  std::vector<double> out(3 * s.x.size());
  for (int k = 0; k < nc; ++k) {
    const std::size_t o = static_cast<std::size_t>(k) * nv;
    double m[3] = {0, 0, 0};
    for (int i = 0; i < nv; ++i) {
      m[0] += s.x[o + i];
      m[1] += s.y[o + i];
      m[2] += s.z[o + i];
    }
    for (double& v : m) v /= nv;
    for (int i = 0; i < nv; ++i) {
      out[3 * (o + i)] = s.x[o + i] - m[0];
      out[3 * (o + i) + 1] = s.y[o + i] - m[1];
      out[3 * (o + i) + 2] = s.z[o + i] - m[2];
    }
  }
  return out;
}

double rms_difference(const std::vector<double>& a, const std::vector<double>& b) {
  double s = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) s += (a[i] - b[i]) * (a[i] - b[i]);
  return std::sqrt(s / static_cast<double>(a.size() / 3));
}

}  // namespace

double ab2_stable_step(double lambda_re, double lambda_im, double tau_max) {
  const std::complex<double> lambda(lambda_re, lambda_im);
  // Stable for small tau when Re lambda < 0; find the first tau where the modulus exceeds 1 by a scan, then bisect.
  const double tol = 1e-12;
  auto unstable = [&](double tau) { return ab2_root_modulus(lambda * tau) > 1.0 + tol; };
  const int n = 2000;
  double lo = 0.0;
  for (int i = 1; i <= n; ++i) {
    const double tau = tau_max * i / n;
    if (unstable(tau)) {
      double hi = tau;
      for (int it = 0; it < 60; ++it) {
        const double mid = 0.5 * (lo + hi);
        (unstable(mid) ? hi : lo) = mid;
      }
      return lo;
    }
    lo = tau;
  }
  return tau_max;
}

namespace {

// The Arnoldi measurement with finite-difference step `rms` (probe_stability's); `u0` the velocities at x0.
StabilityEstimate arnoldi_estimate(Simulation& sim, const StabilityProbeOptions& opt, double rms,
                                   const std::vector<double>& x0, const std::vector<double>& u0) {
  const std::size_t n = x0.size();
  const int m = std::min<int>(opt.iterations, static_cast<int>(n));
  const double gd = sim.config().flow.shear_rate;
  std::vector<double> u;
  StabilityEstimate e;
  e.rms_displacement = rms;
  // eps v with |v| = 1 moves the nodes by eps / sqrt(nodes) rms.
  const double eps = rms * std::sqrt(static_cast<double>(n / 3));

  Eigen::MatrixXd V(static_cast<Eigen::Index>(n), m + 1);
  Eigen::MatrixXd Hs = Eigen::MatrixXd::Zero(m + 1, m);
  std::mt19937_64 rng(opt.seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  for (std::size_t i = 0; i < n; ++i) V(static_cast<Eigen::Index>(i), 0) = gauss(rng);
  V.col(0).normalize();
  std::vector<double> xp(n);
  int steps = m;
  for (int j = 0; j < m; ++j) {
    for (std::size_t i = 0; i < n; ++i) xp[i] = x0[i] + eps * V(static_cast<Eigen::Index>(i), j);
    sim.velocities_at(xp, u);
    ++e.evaluations;
    Eigen::VectorXd w(static_cast<Eigen::Index>(n));
    // Strain units: J / gammadot.
    for (std::size_t i = 0; i < n; ++i) w(static_cast<Eigen::Index>(i)) = (u[i] - u0[i]) / (eps * gd);
    for (int pass = 0; pass < 2; ++pass)  // modified Gram-Schmidt, twice (the vectors must stay orthogonal)
      for (int i = 0; i <= j; ++i) {
        const double hij = V.col(i).dot(w);
        Hs(i, j) += hij;
        w -= hij * V.col(i);
      }
    const double beta = w.norm();
    Hs(j + 1, j) = beta;
    if (beta < 1e-12 * Hs.col(j).norm()) {  // invariant subspace found: its Ritz values are exact
      steps = j + 1;
      break;
    }
    V.col(j + 1) = w / beta;
  }
  const Eigen::MatrixXd Hm = Hs.topLeftCorner(steps, steps);
  Eigen::EigenSolver<Eigen::MatrixXd> es(Hm);
  const Eigen::VectorXcd ritz = es.eigenvalues();
  const Eigen::MatrixXcd Y = es.eigenvectors();
  const double hlast = Hs(steps, steps - 1);

  e.h = sim.geometry().global_min_edge;
  e.ca = sim.ca_step();
  // The top of the spectrum: Ritz values within a factor 2 of the largest modulus that have converged (residual
  // below 10 % of their modulus) each bound the step; the smallest bound wins.
  int top = 0;
  for (int i = 1; i < steps; ++i)
    if (std::abs(ritz(i)) > std::abs(ritz(top))) top = i;
  e.lambda_re = ritz(top).real();
  e.lambda_im = ritz(top).imag();
  e.lambda_abs = std::abs(ritz(top));
  auto residual = [&](int i) { return std::abs(hlast * Y(steps - 1, i)) / std::max(std::abs(ritz(i)), 1e-300); };
  e.ritz_residual = residual(top);
  e.c = e.lambda_abs * e.ca * e.h;
  const double unit = e.ca * e.h;  // dt = cfl * unit
  double tau = 1e300;
  for (int i = 0; i < steps; ++i) {
    if (std::abs(ritz(i)) < 0.5 * e.lambda_abs || residual(i) > 0.1) continue;
    tau = std::min(tau, ab2_stable_step(ritz(i).real(), ritz(i).imag(), 10.0 / e.lambda_abs));
  }
  if (tau == 1e300) tau = ab2_stable_step(e.lambda_re, e.lambda_im, 10.0 / e.lambda_abs);
  e.cfl_crit = tau / unit;
  return e;
}

}  // namespace

StabilityEstimate probe_stability(Simulation& sim, const StabilityProbeOptions& opt) {
  if (opt.iterations < 2) throw std::invalid_argument("probe_stability: iterations must be >= 2");
  const std::vector<double> x0 = sim.positions();
  std::vector<double> u0;
  sim.velocities_at(x0, u0);
  StabilityEstimate e = arnoldi_estimate(sim, opt, opt.rms_displacement, x0, u0);
  e.evaluations += 1;  // u0
  if (e.lambda_re > 0.0) {
    // A growing top value: the step crossed a jump of the velocity (see the header). Measured again with a larger
    // step, which a jump of the interpolation's size no longer dominates; kept only if its top value decays.
    StabilityEstimate again = arnoldi_estimate(sim, opt, 100.0 * opt.rms_displacement, x0, u0);
    again.evaluations += e.evaluations;
    if (again.lambda_re <= 0.0) {
      again.discarded_growth = e.lambda_re;
      return again;
    }
    e.evaluations = again.evaluations;
  }
  return e;
}

GrowthResult perturbation_growth(Simulation& reference, Simulation& perturbed, double dt, int steps,
                                 double amplitude, std::uint64_t seed, double stop_growth) {
  std::vector<double> x = perturbed.positions();
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, amplitude / std::sqrt(3.0));
  for (double& v : x) v += gauss(rng);
  perturbed.set_positions(x);
  GrowthResult r;
  const double d0 = rms_difference(shape_coordinates(reference), shape_coordinates(perturbed));
  for (r.steps = 0; r.steps < steps;) {
    const StepInfo a = reference.advance_fixed(dt), b = perturbed.advance_fixed(dt);
    ++r.steps;
    // Above the limit the round-off of the unperturbed run seeds the unstable modes too: either run failing is the
    // instability (at the chosen step it is a failure of the check).
    if (a.stop != StopReason::None || b.stop != StopReason::None) {
      r.blew_up = true;
      r.growth = std::numeric_limits<double>::infinity();
      return r;
    }
    r.growth = rms_difference(shape_coordinates(reference), shape_coordinates(perturbed)) / d0;
    if (!(r.growth <= stop_growth)) break;
  }
  return r;
}

}  // namespace capsflow
