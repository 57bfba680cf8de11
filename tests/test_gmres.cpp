// Restarted GMRES (src/host/solver/gmres.hpp) against a direct solve (Eigen's LU) of nonsymmetric systems, with and
// without restarts; the iteration cap and the zero right-hand side; the rigid-motion preconditioner's algebra
// (src/host/solver/rigid_preconditioner.hpp).
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>
#include <vector>

#include "host/solver/gmres.hpp"
#include "host/solver/rigid_preconditioner.hpp"

namespace capsflow::test {
namespace {

// A = (1+lambda)/2 I + M with M a random matrix of spectral radius ~0.4: the shape of the interface equation.
Eigen::MatrixXd test_matrix(int n, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> d(0.0, 0.4 / std::sqrt(static_cast<double>(n)));
  Eigen::MatrixXd A(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) A(i, j) = d(rng) + (i == j ? 1.5 : 0.0);
  return A;
}

GmresResult solve(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, Eigen::VectorXd& x, GmresOptions opt) {
  const auto n = static_cast<std::size_t>(A.rows());
  auto apply = [&](const double* in, double* out) {
    Eigen::Map<const Eigen::VectorXd> vin(in, A.rows());
    Eigen::Map<Eigen::VectorXd> vout(out, A.rows());
    vout = A * vin;
  };
  return gmres(n, apply, b.data(), x.data(), opt);
}

TEST(Gmres, MatchesADirectSolve) {
  const int n = 120;
  const Eigen::MatrixXd A = test_matrix(n, 7);
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(n, -1.0, 2.0).array().sin();
  const Eigen::VectorXd exact = A.partialPivLu().solve(b);
  for (int restart : {5, 30, 200}) {
    Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
    GmresOptions opt;
    opt.tolerance = 1e-10;
    opt.restart = restart;
    opt.max_iterations = 1000;
    const GmresResult r = solve(A, b, x, opt);
    EXPECT_TRUE(r.converged) << restart;
    EXPECT_LE(r.residual, 1e-10);
    // The estimate is the true residual (up to rounding).
    EXPECT_NEAR((b - A * x).norm() / b.norm(), r.residual, 1e-12) << restart;
    EXPECT_LT((x - exact).norm() / exact.norm(), 1e-9) << restart;
  }
}

TEST(Gmres, FirstGuessIsUsedAndAnExactOneCostsOneApplication) {
  const int n = 40;
  const Eigen::MatrixXd A = test_matrix(n, 3);
  const Eigen::VectorXd b = Eigen::VectorXd::Ones(n);
  Eigen::VectorXd x = A.partialPivLu().solve(b);
  const GmresResult r = solve(A, b, x, GmresOptions{});
  EXPECT_TRUE(r.converged);
  EXPECT_EQ(r.iterations, 1);
}

TEST(Gmres, ReportsWhenTheCapStopsIt) {
  const int n = 80;
  const Eigen::MatrixXd A = test_matrix(n, 11);
  const Eigen::VectorXd b = Eigen::VectorXd::Ones(n);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
  GmresOptions opt;
  opt.tolerance = 1e-14;
  opt.restart = 3;
  opt.max_iterations = 6;
  const GmresResult r = solve(A, b, x, opt);
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.iterations, 6);
  EXPECT_GT(r.residual, 1e-14);
  EXPECT_LT(r.residual, 1.0);  // it still reduced the residual
}

TEST(Gmres, ZeroRightHandSideGivesZero) {
  Eigen::MatrixXd A = test_matrix(10, 1);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(10), x = Eigen::VectorXd::Ones(10);
  const GmresResult r = solve(A, b, x, GmresOptions{});
  EXPECT_TRUE(r.converged);
  EXPECT_EQ(x.norm(), 0.0);
}

// M leaves each capsule's rigid motions as they are (A's eigenvalue 1 there), scales what is orthogonal to them by
// 2/(1 + lambda) (A's modes about (1 + lambda)/2), and the inverse undoes it; on random node clouds of two capsules of
// different viscosity ratios, blocked [x..., y..., z...] as the interface solve stores them.
TEST(RigidMotionPreconditioner, KeepsRigidMotionsScalesTheRestAndInverts) {
  const int ncap = 2, nv = 40;
  const std::size_t n = static_cast<std::size_t>(ncap) * nv;
  std::mt19937_64 rng(7);
  std::normal_distribution<double> d(0.0, 1.0);
  std::vector<double> x(n), y(n), z(n);
  for (std::size_t i = 0; i < n; ++i) {
    x[i] = d(rng) + (i < static_cast<std::size_t>(nv) ? 0.0 : 5.0);
    y[i] = 0.5 * d(rng) + 3.0;
    z[i] = 2.0 * d(rng);
  }
  const std::vector<double> lambda = {5.0, 0.2};
  RigidMotionPreconditioner m;
  m.set_geometry(ncap, nv, x.data(), y.data(), z.data(), lambda);
  ASSERT_EQ(m.size(), 3 * n);
  std::vector<double> rigid(3 * n), radial(3 * n), out(3 * n), back(3 * n), v(3 * n);
  for (int k = 0; k < ncap; ++k) {
    const std::size_t o = static_cast<std::size_t>(k) * nv;
    double c[3] = {0.0, 0.0, 0.0};
    for (int a = 0; a < nv; ++a) {
      c[0] += x[o + a] / nv;
      c[1] += y[o + a] / nv;
      c[2] += z[o + a] / nv;
    }
    const double U[3] = {0.3 - k, 1.1, -0.7}, W[3] = {0.2, -0.9 + k, 0.4};
    for (int a = 0; a < nv; ++a) {
      const double r[3] = {x[o + a] - c[0], y[o + a] - c[1], z[o + a] - c[2]};
      const double wr[3] = {W[1] * r[2] - W[2] * r[1], W[2] * r[0] - W[0] * r[2], W[0] * r[1] - W[1] * r[0]};
      for (int cc = 0; cc < 3; ++cc) {
        rigid[cc * n + o + a] = U[cc] + wr[cc];
        radial[cc * n + o + a] = r[cc];  // orthogonal to translations (sum r = 0) and rotations (r . (w x r) = 0)
      }
    }
  }
  m.apply(rigid.data(), out.data(), false);
  for (std::size_t i = 0; i < 3 * n; ++i) EXPECT_NEAR(out[i], rigid[i], 1e-12) << i;
  m.apply(radial.data(), out.data(), false);
  for (std::size_t i = 0; i < 3 * n; ++i) {
    const double want = radial[i] * 2.0 / (1.0 + lambda[(i % n) / nv]);
    EXPECT_NEAR(out[i], want, 1e-12) << i;
  }
  for (double& e : v) e = d(rng);
  m.apply(v.data(), out.data(), false);
  m.apply(out.data(), back.data(), true);
  for (std::size_t i = 0; i < 3 * n; ++i) EXPECT_NEAR(back[i], v[i], 1e-12) << i;
  EXPECT_THROW(m.set_geometry(ncap, nv, x.data(), y.data(), z.data(), {5.0}), std::invalid_argument);
}

}  // namespace
}  // namespace capsflow::test
