// Membrane mechanics (docs/method.md §2.3; issue 3): energy gradient, invariances, inflation tension, flat-sheet
// uniaxial tension (docs/validation.md, VD 3), backend agreement.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <ostream>
#include <stdexcept>
#include <cmath>
#include <cstdlib>
#include <vector>

#include "host/state/capsule_state.hpp"
#include "host/base/errors.hpp"
#include "host/state/icosphere.hpp"
#include "kernels/membrane_forces.hpp"
#include "support/backends.hpp"
#include "support/test_util.hpp"

using namespace capsflow;

namespace capsflow {
// Readable parameter values in test output.
inline void PrintTo(MembraneLaw l, std::ostream* os) { *os << (l == MembraneLaw::NeoHookean ? "neo-Hookean" : "Skalak"); }
}  // namespace capsflow

namespace {

MembraneParameters params_for(MembraneLaw law, double C = 1.0, double beta = 0.1) {
  MembraneParameters p;
  p.law = law;
  p.skalak_C = C;
  p.inflation = beta;
  return p;
}

// ncap capsules of two species, each strained by a random affine map plus random nodal noise.
CapsuleState random_capsules(MembraneLaw law, int level, int ncap, double noise, std::uint64_t seed) {
  CapsuleState s(level, params_for(law, 2.5));
  const int soft = s.add_species(0.4), stiff = s.add_species(0.1);
  for (int k = 0; k < ncap; ++k) s.add_capsule({3.0 * k, 1.5, -0.5 * k}, 1.0 + 0.1 * (k % 3), k % 2 ? soft : stiff);
  const int nv = s.nodes_per_capsule();
  const auto aff = test::uniform_values(9 * static_cast<std::size_t>(ncap), -0.25, 0.25, seed);
  const auto d = test::uniform_values(3 * s.x.size(), -noise, noise, seed + 1);
  for (int k = 0; k < ncap; ++k) {
    const double c[3] = {3.0 * k, 1.5, -0.5 * k};
    const double* A = &aff[9 * k];
    for (int i = k * nv; i < (k + 1) * nv; ++i) {
      const double r[3] = {s.x[i] - c[0], s.y[i] - c[1], s.z[i] - c[2]};
      s.x[i] = c[0] + r[0] + A[0] * r[0] + A[1] * r[1] + A[2] * r[2] + d[3 * i];
      s.y[i] = c[1] + r[1] + A[3] * r[0] + A[4] * r[1] + A[5] * r[2] + d[3 * i + 1];
      s.z[i] = c[2] + r[2] + A[6] * r[0] + A[7] * r[1] + A[8] * r[2] + d[3 * i + 2];
    }
  }
  return s;
}

double total(const std::vector<double>& v) {
  double s = 0.0;
  for (double e : v) s += e;
  return s;
}

}  // namespace

class MembraneLawTest : public ::testing::TestWithParam<MembraneLaw> {};

TEST_P(MembraneLawTest, ForcesAreMinusEnergyGradient) {
  CapsuleState s = random_capsules(GetParam(), 1, 2, 0.05, 11);
  s.compute_membrane_forces(Backend::Serial);
  const std::vector<double> F[3] = {s.Fx, s.Fy, s.Fz};
  std::vector<double>* X[3] = {&s.x, &s.y, &s.z};
  double fmax = 0.0, err = 0.0;
  const double h = 1e-5;
  for (std::size_t i = 0; i < s.x.size(); ++i)
    for (int d = 0; d < 3; ++d) {
      const double x0 = (*X[d])[i];
      (*X[d])[i] = x0 + h;
      const double ep = total(s.membrane_energy());
      (*X[d])[i] = x0 - h;
      const double em = total(s.membrane_energy());
      (*X[d])[i] = x0;
      const double fd = -(ep - em) / (2.0 * h);
      err = std::max(err, std::abs(fd - F[d][i]));
      fmax = std::max(fmax, std::abs(F[d][i]));
    }
  ASSERT_GT(fmax, 0.0);
  EXPECT_LT(err / fmax, 1e-6) << "max |F_fd - F| / max |F| = " << err / fmax;
  std::printf("finite-difference check: max abs error / max abs F = %.3e\n", err / fmax);
}

TEST_P(MembraneLawTest, ZeroNetForceAndTorquePerCapsule) {
  CapsuleState s = random_capsules(GetParam(), 2, 4, 0.05, 21);
  s.compute_membrane_forces(Backend::Serial);
  const int nv = s.nodes_per_capsule();
  for (int k = 0; k < s.num_capsules(); ++k) {
    double F[3] = {0, 0, 0}, T[3] = {0, 0, 0}, fmax = 0.0, rmax = 0.0, c[3] = {0, 0, 0};
    for (int i = k * nv; i < (k + 1) * nv; ++i) {
      c[0] += s.x[i] / nv;
      c[1] += s.y[i] / nv;
      c[2] += s.z[i] / nv;
    }
    for (int i = k * nv; i < (k + 1) * nv; ++i) {
      const double r[3] = {s.x[i] - c[0], s.y[i] - c[1], s.z[i] - c[2]};
      F[0] += s.Fx[i];
      F[1] += s.Fy[i];
      F[2] += s.Fz[i];
      T[0] += r[1] * s.Fz[i] - r[2] * s.Fy[i];
      T[1] += r[2] * s.Fx[i] - r[0] * s.Fz[i];
      T[2] += r[0] * s.Fy[i] - r[1] * s.Fx[i];
      fmax = std::max({fmax, std::abs(s.Fx[i]), std::abs(s.Fy[i]), std::abs(s.Fz[i])});
      rmax = std::max(rmax, std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]));
    }
    ASSERT_GT(fmax, 1e-3);
    for (int d = 0; d < 3; ++d) {
      EXPECT_NEAR(F[d], 0.0, 1e-13 * fmax * nv) << "capsule " << k;
      EXPECT_NEAR(T[d], 0.0, 1e-13 * fmax * rmax * nv) << "capsule " << k;
    }
    // The density integrates to the same (zero) net force: sum_i f_i A_i = sum_i F_i.
    double G = 0.0;
    for (int i = k * nv; i < (k + 1) * nv; ++i) G += s.fx[i] * s.node_area[i];
    EXPECT_NEAR(G, F[0], 1e-12 * fmax * nv);
  }
}

TEST_P(MembraneLawTest, ForcesRotateWithTheCapsuleAndIgnoreTranslation) {
  CapsuleState s = random_capsules(GetParam(), 2, 2, 0.05, 31);
  s.compute_membrane_forces(Backend::Serial);
  const auto Fx = s.Fx, Fy = s.Fy, Fz = s.Fz;
  // Rotation about an oblique axis (Rodrigues), then a translation.
  const double ax[3] = {1 / std::sqrt(3.0), -1 / std::sqrt(3.0), 1 / std::sqrt(3.0)}, th = 0.7;
  double R[3][3];
  const double c = std::cos(th), sn = std::sin(th);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) R[i][j] = (i == j ? c : 0.0) + (1 - c) * ax[i] * ax[j];
  R[0][1] -= sn * ax[2];
  R[0][2] += sn * ax[1];
  R[1][0] += sn * ax[2];
  R[1][2] -= sn * ax[0];
  R[2][0] -= sn * ax[1];
  R[2][1] += sn * ax[0];
  CapsuleState r = s;
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    const double p[3] = {s.x[i], s.y[i], s.z[i]};
    r.x[i] = R[0][0] * p[0] + R[0][1] * p[1] + R[0][2] * p[2];
    r.y[i] = R[1][0] * p[0] + R[1][1] * p[1] + R[1][2] * p[2];
    r.z[i] = R[2][0] * p[0] + R[2][1] * p[1] + R[2][2] * p[2];
  }
  r.compute_membrane_forces(Backend::Serial);
  double fmax = 0.0, err = 0.0;
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    const double f[3] = {Fx[i], Fy[i], Fz[i]}, g[3] = {r.Fx[i], r.Fy[i], r.Fz[i]};
    for (int d = 0; d < 3; ++d) {
      err = std::max(err, std::abs(R[d][0] * f[0] + R[d][1] * f[1] + R[d][2] * f[2] - g[d]));
      fmax = std::max(fmax, std::abs(f[d]));
    }
  }
  EXPECT_LT(err / fmax, 1e-12);

  CapsuleState t = s;
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    t.x[i] += 7.25;
    t.y[i] -= 3.5;
    t.z[i] += 11.0;
  }
  t.compute_membrane_forces(Backend::Serial);
  EXPECT_LT(test::max_rel_error(t.Fx, Fx), 1e-11);
  EXPECT_LT(test::max_rel_error(t.Fy, Fy), 1e-11);
  EXPECT_LT(test::max_rel_error(t.Fz, Fz), 1e-11);
}

TEST_P(MembraneLawTest, UnstrainedCapsuleHasNoForce) {
  CapsuleState s(2, params_for(GetParam(), 1.0, 0.0));
  s.add_capsule({0.3, 0.2, 0.1}, 1.0, s.add_species(0.2));
  s.compute_membrane_forces(Backend::Serial);
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    EXPECT_NEAR(s.Fx[i], 0.0, 1e-14);
    EXPECT_NEAR(s.Fy[i], 0.0, 1e-14);
    EXPECT_NEAR(s.Fz[i], 0.0, 1e-14);
  }
}

INSTANTIATE_TEST_SUITE_P(Laws, MembraneLawTest, ::testing::Values(MembraneLaw::NeoHookean, MembraneLaw::Skalak),
                         [](const ::testing::TestParamInfo<MembraneLaw>& p) {
                           return p.param == MembraneLaw::NeoHookean ? std::string("NeoHookean")
                                                                        : std::string("Skalak");
                         });

// Isotropic pre-inflation lambda = 1.1: uniform tension T = Gs (1 - lambda^-6) (validation.md, VD 3). On a sphere of
// radius a the membrane load is 2T/a along the normal; the elastic force pulls the inflated membrane inward and the
// force on the fluid is that same force (P1), so f.n -> -2T/a.
TEST(MembraneInflation, NormalDensityMatchesLaplaceLawAndConverges) {
  const double Ca = 0.5, a = 1.0, Gs = a / Ca;
  const double T = Gs * (1.0 - std::pow(1.1, -6.0));
  EXPECT_NEAR(T / Gs, 0.4355, 5e-5);
  // The pointwise error at the 12 valence-5 nodes (the icosahedron's vertices) does not vanish under uniform
  // refinement (lumped areas on an irregular star: ~14 % at every level); everywhere else, and in the mean square,
  // it falls as O(h). The test asserts exactly that, so a regression in either shows.
  double prev_rms = 1e9, prev_max6 = 1e9;
  for (int level = 1; level <= 4; ++level) {
    CapsuleState s(level);
    s.add_capsule({0.5, 2.0, -1.0}, a, s.add_species(Ca));
    s.compute_membrane_forces(Backend::Serial);
    const TriMesh& m = s.mesh();
    double max_err = 0.0, max6 = 0.0, rms = 0.0, max_tan = 0.0, load = 0.0, area = 0.0;
    const long nn = s.num_nodes();
    for (long i = 0; i < nn; ++i) {
      const double n[3] = {s.x[i] - 0.5, s.y[i] - 2.0, s.z[i] + 1.0};  // exact sphere normal (|n| = a = 1)
      const double fn = s.fx[i] * n[0] + s.fy[i] * n[1] + s.fz[i] * n[2];
      ASSERT_LT(fn, 0.0) << "force on the fluid must point inward";
      const double e = (fn + 2.0 * T / a) / (2.0 * T / a);
      max_err = std::max(max_err, std::abs(e));
      if (m.inc_offsets[i + 1] - m.inc_offsets[i] == 6) max6 = std::max(max6, std::abs(e));
      rms += e * e / static_cast<double>(nn);
      load += fn * s.node_area[i];
      area += s.node_area[i];
      const double ft[3] = {s.fx[i] - fn * n[0], s.fy[i] - fn * n[1], s.fz[i] - fn * n[2]};
      max_tan = std::max(max_tan, std::sqrt(ft[0] * ft[0] + ft[1] * ft[1] + ft[2] * ft[2]) / (2.0 * T / a));
    }
    rms = std::sqrt(rms);
    const double mean_err = (load / area + 2.0 * T / a) / (2.0 * T / a);
    std::printf("level %d: f.n rel. error rms %.3e, area-weighted mean %.3e, max %.3e (valence-6 nodes %.3e); "
                "max tangential %.3e\n",
                level, rms, mean_err, max_err, max6, max_tan);
    EXPECT_LT(rms, 0.65 * prev_rms) << "level " << level;
    EXPECT_LT(max6, 0.75 * prev_max6) << "level " << level;
    // Virtual work of a uniform dilation: sum_i F_i.(x_i - c) = -2 T A exactly, so the area-weighted mean is exact.
    EXPECT_LT(std::abs(mean_err), 1e-12) << "level " << level;
    EXPECT_LT(max_err, 0.16) << "level " << level;
    prev_rms = rms;
    prev_max6 = max6;
  }
  EXPECT_LT(prev_rms, 0.011);
}

namespace {

// Flat square sheet [0,1]^2 with n x n nodes, reference = itself; returns tension per current boundary length.
struct SheetResult {
  double T1, T2, interior_max;
};
SheetResult stretch_sheet(MembraneLaw law, double Cs, double Gs, double l1, double l2) {
  const int n = 9;
  TriMesh m;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      m.x.push_back(i / double(n - 1));
      m.y.push_back(j / double(n - 1));
      m.z.push_back(0.0);
    }
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const int a = j * n + i, b = a + 1, c = a + n, d = c + 1;
      // alternate the diagonal so the mesh has no preferred direction
      if ((i + j) % 2) {
        for (int v : {a, b, d, a, d, c}) m.tri.push_back(v);
      } else {
        for (int v : {a, b, c, b, d, c}) m.tri.push_back(v);
      }
    }
  build_mesh_connectivity(m);
  const int nv = m.num_nodes(), nt = m.num_triangles();
  std::vector<double> A0(nt), g1x(nt), g1y(nt), g2x(nt), g2y(nt);
  membrane_reference(1, nv, nt, m.tri.data(), m.x.data(), m.y.data(), m.z.data(), A0.data(), g1x.data(), g1y.data(),
                     g2x.data(), g2y.data());
  std::vector<double> x(nv), y(nv), z(nv, 0.0);
  // A tilt out of the plane too: the law must not care where the sheet sits in 3D.
  for (int i = 0; i < nv; ++i) {
    x[i] = l1 * m.x[i];
    y[i] = l2 * m.y[i];
  }
  std::vector<double> F[3], f[3], area(nv), work(10 * static_cast<std::size_t>(nt));
  for (int d = 0; d < 3; ++d) {
    F[d].resize(nv);
    f[d].resize(nv);
  }
  const MeshTopology topo{nv, nt, m.tri.data(), m.inc_offsets.data(), m.inc_tri.data(), m.inc_corner.data()};
  const MembraneReference ref{A0.data(), g1x.data(), g1y.data(), g2x.data(), g2y.data()};
  membrane_forces(Backend::Serial, &law, &Cs, 1, topo, ref, &Gs, x.data(), y.data(), z.data(), MembraneWork{work.data()},
                  F[0].data(), F[1].data(), F[2].data(), area.data(), f[0].data(), f[1].data(), f[2].data());
  // The load that holds the sheet is -F; per current edge length it is the Cauchy tension.
  SheetResult r{0, 0, 0};
  for (int j = 0; j < n; ++j) r.T1 -= F[0][j * n + (n - 1)] / l2;
  for (int i = 0; i < n; ++i) r.T2 -= F[1][(n - 1) * n + i] / l1;
  for (int j = 1; j + 1 < n; ++j)
    for (int i = 1; i + 1 < n; ++i)
      r.interior_max = std::max({r.interior_max, std::abs(F[0][j * n + i]), std::abs(F[1][j * n + i]),
                                 std::abs(F[2][j * n + i])});
  return r;
}

}  // namespace

TEST(MembraneSheet, NeoHookeanUniaxialTension) {
  const double Gs = 2.0;
  for (double l1 : {1.5, 2.0}) {
    const double l2 = 1.0 / std::sqrt(l1);
    const double expected = Gs * (l1 * l1 * l1 - 1.0) / std::pow(l1, 1.5);
    const SheetResult r = stretch_sheet(MembraneLaw::NeoHookean, 0.0, Gs, l1, l2);
    EXPECT_NEAR(r.T1, expected, 1e-12 * expected) << "lambda1 " << l1;
    EXPECT_NEAR(r.T2, 0.0, 1e-12 * expected);
    EXPECT_LT(r.interior_max, 1e-12 * expected);
  }
  // VD 3 (docs/validation.md) quotes 1.2928 and 2.4749.
  EXPECT_NEAR(stretch_sheet(MembraneLaw::NeoHookean, 0.0, 1.0, 1.5, 1.0 / std::sqrt(1.5)).T1, 1.2928, 5e-5);
  EXPECT_NEAR(stretch_sheet(MembraneLaw::NeoHookean, 0.0, 1.0, 2.0, 1.0 / std::sqrt(2.0)).T1, 2.4749, 5e-5);
}

TEST(MembraneSheet, NeoHookeanIsotropicStretch) {
  const SheetResult r = stretch_sheet(MembraneLaw::NeoHookean, 0.0, 1.0, 1.1, 1.1);
  EXPECT_NEAR(r.T1, 1.0 - std::pow(1.1, -6.0), 1e-13);
  EXPECT_NEAR(r.T2, 1.0 - std::pow(1.1, -6.0), 1e-13);
}

TEST(MembraneSheet, SkalakUniaxialTension) {
  // Skalak principal tensions (docs/method.md):
  //   T1 = Gs/(l1 l2) [l1^2 (l1^2 - 1) + C (l1 l2)^2 ((l1 l2)^2 - 1)],  T2 likewise with l1 <-> l2.
  const double Gs = 1.5;
  auto T1 = [&](double C, double a, double b) {
    return Gs / (a * b) * (a * a * (a * a - 1) + C * a * a * b * b * (a * a * b * b - 1));
  };
  for (double C : {0.5, 1.0, 10.0})
    for (double l1 : {1.5, 2.0}) {
      // T2(l1, l2) = 0 by bisection on (0, 1]: T2 < 0 at small l2, > 0 at l2 = 1.
      double lo = 1e-3, hi = 1.0;
      for (int it = 0; it < 200; ++it) {
        const double mid = 0.5 * (lo + hi);
        (T1(C, mid, l1) < 0.0 ? lo : hi) = mid;
      }
      const double l2 = 0.5 * (lo + hi);
      EXPECT_NEAR(l2 * l2, (1 + C * l1 * l1) / (1 + C * l1 * l1 * l1 * l1), 1e-12);  // closed form, cross-check
      const SheetResult r = stretch_sheet(MembraneLaw::Skalak, C, Gs, l1, l2);
      const double expected = T1(C, l1, l2);
      EXPECT_NEAR(r.T1, expected, 1e-11 * expected) << "C " << C << " lambda1 " << l1;
      EXPECT_NEAR(r.T2, 0.0, 1e-11 * expected);
      EXPECT_LT(r.interior_max, 1e-11 * expected);
    }
}

// threads and device against the serial oracle on many randomly deformed capsules.
class MembraneBackendTest : public test::OnEachBackend {};

TEST_P(MembraneBackendTest, MatchesSerial) {
  for (MembraneLaw law : {MembraneLaw::NeoHookean, MembraneLaw::Skalak}) {
    CapsuleState s = random_capsules(law, 2, 50, 0.03, 41);
    CapsuleState b = s;
    s.compute_membrane_forces(Backend::Serial);
    b.compute_membrane_forces(GetParam());
    const double tol = GetParam() == Backend::Threads ? 0.0 : 1e-14;  // same sums in the same order on the host
    EXPECT_LE(test::max_rel_error(b.Fx, s.Fx), tol);
    EXPECT_LE(test::max_rel_error(b.Fy, s.Fy), tol);
    EXPECT_LE(test::max_rel_error(b.Fz, s.Fz), tol);
    EXPECT_LE(test::max_rel_error(b.fx, s.fx), tol);
    EXPECT_LE(test::max_rel_error(b.fy, s.fy), tol);
    EXPECT_LE(test::max_rel_error(b.fz, s.fz), tol);
    EXPECT_LE(test::max_rel_error(b.node_area, s.node_area), tol);
  }
}

CAPSFLOW_ON_PARALLEL_BACKENDS(MembraneBackendTest);

TEST(MembraneBackend, DeviceWithoutOffloadIsRefused) {
  if (backend_available(Backend::Device)) GTEST_SKIP() << "device present";
  CapsuleState s(0);
  s.add_capsule({0, 0, 0}, 1.0, s.add_species(1.0));
  EXPECT_THROW(s.compute_membrane_forces(Backend::Device), BackendUnavailable);
  // A caller that skips require_backend() gets an error from the kernel, not a silent no-op.
  std::vector<double> w(10 * 20), out(7 * 12);
  double* o = out.data();
  const MembraneLaw law = MembraneLaw::NeoHookean;
  const double Cs = 1.0;
  EXPECT_THROW(membrane_forces(Backend::Device, &law, &Cs, 1, s.topology(), s.reference(),
                               s.shear_modulus().data(), s.x.data(), s.y.data(), s.z.data(), MembraneWork{w.data()},
                               o, o + 12, o + 24, o + 36, o + 48, o + 60, o + 72),
               std::logic_error);
}

TEST(CapsuleState, RejectsBadInput) {
  CapsuleState s(1);
  EXPECT_THROW(s.add_species(0.0), InputError);
  EXPECT_THROW(s.add_capsule({0, 0, 0}, 1.0, 0), InputError);  // no species yet
  const int sp = s.add_species(0.2);
  EXPECT_THROW(s.add_capsule({0, 0, 0}, -1.0, sp), InputError);
  EXPECT_THROW(CapsuleState(7), InputError);
  EXPECT_EQ(s.add_capsule({0, 0, 0}, 2.0, sp), 0);
  EXPECT_DOUBLE_EQ(s.shear_modulus()[0], 2.0 / 0.2);  // Gs = mu gammadot a / Ca
}

// Per-node output fields (membrane_node_fields, docs/output_format.md format 5) against closed forms.
namespace {

// Equibiaxial stretch lambda: principal Cauchy tension T and energy W per reference area, from W(l1, l2) by hand:
// T1 = (1/l2) dW/dl1. neo-Hookean W = Gs/2 (l1^2 + l2^2 - 3 + 1/(l1 l2)^2) -> T = Gs (1 - lambda^-6); Skalak
// W = Gs/4 (I1^2 + 2 I1 - 2 I2 + C I2^2) -> T = Gs (lambda^2 - 1 + C lambda^2 (lambda^4 - 1)).
struct Equibiaxial {
  double T, W;
};
Equibiaxial equibiaxial(MembraneLaw law, double Gs, double C, double l) {
  const double I1 = 2 * l * l - 2, I2 = l * l * l * l - 1;
  if (law == MembraneLaw::NeoHookean) return {Gs * (1 - std::pow(l, -6.0)), 0.5 * Gs * (2 * l * l - 3 + std::pow(l, -4.0))};
  return {Gs * (l * l - 1 + C * l * l * (l * l * l * l - 1)), 0.25 * Gs * (I1 * I1 + 2 * I1 - 2 * I2 + C * I2 * I2)};
}

class MembraneNodeFieldsTest : public ::testing::TestWithParam<MembraneLaw> {};

TEST_P(MembraneNodeFieldsTest, AnUnstressedCapsuleHasNoTractionTensionOrEnergy) {
  CapsuleState s(2, params_for(GetParam(), 2.5, 0.0));
  s.add_capsule({0.3, 0.2, 0.1}, 1.0, s.add_species(0.2));
  const MembraneNodeFields m = membrane_node_fields(s);
  const double Gs = s.shear_modulus()[0];
  ASSERT_EQ(m.traction_jump.size(), 3 * s.x.size());
  for (double v : m.traction_jump) EXPECT_NEAR(v, 0.0, 1e-13 * Gs);
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    EXPECT_NEAR(m.tension_max[i], 0.0, 1e-13 * Gs);
    EXPECT_NEAR(m.tension_min[i], 0.0, 1e-13 * Gs);
    EXPECT_NEAR(m.energy_density[i], 0.0, 1e-13 * Gs);
  }
}

// The inflated sphere is a homothety of its reference: every element is stretched equibiaxially by lambda = 1 + beta
// exactly, so the tensions and the energy density are the closed forms to round-off at every node. The traction
// jump is Laplace's 2T/a along the outward normal: exactly in the area-weighted mean (virtual work of a uniform
// dilation), within the lumping's discretisation error node by node.
TEST_P(MembraneNodeFieldsTest, AnInflatedSphereHasTheAnalyticTensionAndLaplacesTractionJump) {
  const double beta = 0.1, Ca = 0.5, a = 1.0, C = 2.5;
  CapsuleState s(3, params_for(GetParam(), C, beta));
  s.add_capsule({0.5, 2.0, -1.0}, a, s.add_species(Ca));
  const double Gs = a / Ca;
  const Equibiaxial ex = equibiaxial(GetParam(), Gs, C, 1.0 + beta);
  ASSERT_GT(ex.T, 0.0);
  const MembraneNodeFields m = membrane_node_fields(s);
  s.compute_membrane_forces(Backend::Serial);  // for the lumped node areas only
  const double laplace = 2.0 * ex.T / a;
  double load = 0.0, area = 0.0, rms = 0.0, max_tan = 0.0;
  const std::size_t nn = s.x.size();
  for (std::size_t i = 0; i < nn; ++i) {
    EXPECT_NEAR(m.tension_max[i], ex.T, 1e-12 * ex.T) << i;
    EXPECT_NEAR(m.tension_min[i], ex.T, 1e-12 * ex.T) << i;
    EXPECT_NEAR(m.energy_density[i], ex.W, 1e-12 * ex.W) << i;
    const double n[3] = {s.x[i] - 0.5, s.y[i] - 2.0, s.z[i] + 1.0};  // outward unit normal (a = 1)
    const double* t = &m.traction_jump[3 * i];
    const double tn = t[0] * n[0] + t[1] * n[1] + t[2] * n[2];
    EXPECT_GT(tn, 0.0) << "the traction jump of an inflated membrane points outward";
    load += tn * s.node_area[i];
    area += s.node_area[i];
    rms += (tn - laplace) * (tn - laplace) / (laplace * laplace * static_cast<double>(nn));
    const double tt[3] = {t[0] - tn * n[0], t[1] - tn * n[1], t[2] - tn * n[2]};
    max_tan = std::max(max_tan, std::sqrt(tt[0] * tt[0] + tt[1] * tt[1] + tt[2] * tt[2]) / laplace);
  }
  EXPECT_NEAR(load / area, laplace, 1e-12 * laplace);
  EXPECT_LT(std::sqrt(rms), 0.03);  // level 3 (MembraneInflation: O(h) away from the 12 valence-5 nodes)
  EXPECT_LT(max_tan, 0.05);
}

// One element under the pure stretch (l1, l2) along rotated in-plane axes, tilted out of the plane: the principal
// tensions are T1(l1, l2) >= T2 = T1(l2, l1) of the law, whatever the orientation.
TEST_P(MembraneNodeFieldsTest, PrincipalTensionsOfAStretchedElementAreTheLawsClosedForm) {
  const double Gs = 1.7, C = 2.5;
  auto T1 = [&](double a, double b) {
    if (GetParam() == MembraneLaw::NeoHookean) return Gs / (a * b) * (a * a - 1.0 / (a * b * a * b));
    return Gs * (a / b) * (a * a - 1 + C * b * b * (a * a * b * b - 1));
  };
  const double X[3][3] = {{0.0, 0.0, 0.0}, {0.9, 0.1, 0.0}, {0.2, 0.7, 0.0}};
  double A0, g1x, g1y, g2x, g2y;
  membrane_reference_element(X[0][0], X[0][1], X[0][2], X[1][0], X[1][1], X[1][2], X[2][0], X[2][1], X[2][2], A0, g1x,
                             g1y, g2x, g2y);
  for (double phi : {0.0, 0.4, 1.3})
    for (auto [l1, l2] : {std::pair{1.3, 0.9}, std::pair{0.8, 1.6}, std::pair{1.2, 1.2}}) {
      // x -> Q_tilt R(phi)^T diag(l1, l2) R(phi) x: stretches l1, l2 along the axes at angle phi, then a tilt.
      const double c = std::cos(phi), s = std::sin(phi), ct = std::cos(0.5), st = std::sin(0.5);
      double x[3][3];
      for (int v = 0; v < 3; ++v) {
        const double u = c * X[v][0] + s * X[v][1], w = -s * X[v][0] + c * X[v][1];
        const double px = c * l1 * u - s * l2 * w, py = s * l1 * u + c * l2 * w;
        x[v][0] = px;
        x[v][1] = ct * py;
        x[v][2] = st * py;
      }
      double t1, t2, W;
      membrane_element_tensions(GetParam(), Gs, C, x[0][0], x[0][1], x[0][2], x[1][0], x[1][1], x[1][2], x[2][0],
                                x[2][1], x[2][2], g1x, g1y, g2x, g2y, t1, t2, W);
      const double big = std::max(T1(l1, l2), T1(l2, l1)), small = std::min(T1(l1, l2), T1(l2, l1));
      EXPECT_NEAR(t1, big, 1e-12 * std::abs(big)) << "phi " << phi << " l1 " << l1 << " l2 " << l2;
      EXPECT_NEAR(t2, small, 1e-12 * std::max(1.0, std::abs(small))) << "phi " << phi << " l1 " << l1 << " l2 " << l2;
    }
}

INSTANTIATE_TEST_SUITE_P(Laws, MembraneNodeFieldsTest, ::testing::Values(MembraneLaw::NeoHookean, MembraneLaw::Skalak),
                         [](const ::testing::TestParamInfo<MembraneLaw>& p) {
                           return p.param == MembraneLaw::NeoHookean ? std::string("NeoHookean")
                                                                        : std::string("Skalak");
                         });

}  // namespace
