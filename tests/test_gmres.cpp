// Restarted GMRES (src/host/solver/gmres.hpp) against a direct solve (Eigen's LU) of nonsymmetric systems, with and
// without restarts; the iteration cap and the zero right-hand side.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>
#include <vector>

#include "host/solver/gmres.hpp"

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

}  // namespace
}  // namespace capsflow::test
