// Capsule geometry (docs/method.md §2.4; issue 3): volume, area, centroid, Taylor deformation, mean velocity,
// node normals, edge lengths; backend agreement.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <ostream>
#include <vector>

#include "host/state/capsule_state.hpp"
#include "kernels/capsule_geometry.hpp"
#include "support/backends.hpp"
#include "support/test_util.hpp"

using namespace capsflow;

namespace {

constexpr double kPi = 3.14159265358979323846;

CapsuleState sphere(int level, double cx, double cy, double cz, double radius) {
  CapsuleState s(level);
  s.add_capsule({cx, cy, cz}, radius, s.add_species(0.3));
  return s;
}

// Independent polyhedron reference: tetrahedra from an arbitrary apex q, and triangle areas.
struct Poly {
  double V = 0, A = 0, c[3] = {0, 0, 0};
};
Poly polyhedron(const CapsuleState& s, int k) {
  const TriMesh& m = s.mesh();
  const int nv = m.num_nodes();
  const double q[3] = {-3.0, 4.0, 0.5};
  Poly p;
  for (int t = 0; t < m.num_triangles(); ++t) {
    double v[3][3];
    for (int c = 0; c < 3; ++c) {
      const int i = k * nv + m.tri[3 * t + c];
      v[c][0] = s.x[i];
      v[c][1] = s.y[i];
      v[c][2] = s.z[i];
    }
    double a[3], b[3], d[3];
    for (int j = 0; j < 3; ++j) {
      a[j] = v[0][j] - q[j];
      b[j] = v[1][j] - q[j];
      d[j] = v[2][j] - q[j];
    }
    const double vol = (a[0] * (b[1] * d[2] - b[2] * d[1]) - a[1] * (b[0] * d[2] - b[2] * d[0]) +
                        a[2] * (b[0] * d[1] - b[1] * d[0])) /
                       6.0;
    p.V += vol;
    for (int j = 0; j < 3; ++j) p.c[j] += vol * (q[j] + v[0][j] + v[1][j] + v[2][j]) / 4.0;
    double e1[3], e2[3];
    for (int j = 0; j < 3; ++j) {
      e1[j] = v[1][j] - v[0][j];
      e2[j] = v[2][j] - v[0][j];
    }
    const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    p.A += 0.5 * std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  }
  for (double& c : p.c) c /= p.V;
  return p;
}

// Maps capsule 0's nodes x -> c + A (x - c).
void map_nodes(CapsuleState& s, const double A[3][3], const double c[3]) {
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    const double r[3] = {s.x[i] - c[0], s.y[i] - c[1], s.z[i] - c[2]};
    s.x[i] = c[0] + A[0][0] * r[0] + A[0][1] * r[1] + A[0][2] * r[2];
    s.y[i] = c[1] + A[1][0] * r[0] + A[1][1] * r[1] + A[1][2] * r[2];
    s.z[i] = c[2] + A[2][0] * r[0] + A[2][1] * r[1] + A[2][2] * r[2];
  }
}

// Stretch diag(s1, s2, s3) with the s1 axis at angle theta from x in the x-y plane.
void ellipsoid_map(double s1, double s2, double s3, double theta, double A[3][3]) {
  const double c = std::cos(theta), s = std::sin(theta);
  const double R[3][3] = {{c, -s, 0}, {s, c, 0}, {0, 0, 1}}, d[3] = {s1, s2, s3};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      A[i][j] = 0.0;
      for (int k = 0; k < 3; ++k) A[i][j] += R[i][k] * d[k] * R[j][k];
    }
}

}  // namespace

TEST(CapsuleGeometry, VolumeAreaCentroidAreThoseOfThePolyhedron) {
  double prev_dv = 1e9, prev_da = 1e9;
  for (int level = 0; level <= 4; ++level) {
    CapsuleState s = sphere(level, 10.5, 3.25, -7.0, 1.3);
    // A random perturbation so the centroid moves off the centre.
    const auto d = test::uniform_values(3 * s.x.size(), -0.05, 0.05, 5 + level);
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      s.x[i] += d[3 * i];
      s.y[i] += d[3 * i + 1];
      s.z[i] += d[3 * i + 2];
    }
    const CapsuleGeometry g = compute_geometry(s, Backend::Serial);
    const Poly p = polyhedron(s, 0);
    EXPECT_NEAR(g.volume[0], p.V, 1e-13 * p.V);
    EXPECT_NEAR(g.area[0], p.A, 1e-13 * p.A);
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(g.centroid[j], p.c[j], 1e-12);

    // Unperturbed: convergence to the sphere 4 pi a^3 / 3, 4 pi a^2, centroid = centre.
    const double a = 1.3;
    CapsuleState u = sphere(level, 10.5, 3.25, -7.0, a);
    const CapsuleGeometry h = compute_geometry(u, Backend::Serial);
    const double dv = std::abs(h.volume[0] / (4 * kPi * a * a * a / 3) - 1), da = std::abs(h.area[0] / (4 * kPi * a * a) - 1);
    std::printf("level %d: volume rel. error %.3e, area rel. error %.3e\n", level, dv, da);
    EXPECT_LT(dv, 0.35 * prev_dv);  // O(h^2): a factor ~4 per level once past level 0
    EXPECT_LT(da, 0.35 * prev_da);
    prev_dv = dv;
    prev_da = da;
    EXPECT_NEAR(h.centroid[0], 10.5, 1e-12);
    EXPECT_NEAR(h.centroid[1], 3.25, 1e-12);
    EXPECT_NEAR(h.centroid[2], -7.0, 1e-12);
    if (level == 2) {  // docs/method.md §2.1 / P12: area 12.33 a^2, volume 4.05 a^3 for a = 1
      EXPECT_NEAR(h.area[0] / (a * a), 12.33, 0.005);
      EXPECT_NEAR(h.volume[0] / (a * a * a), 4.05, 0.005);
    }
  }
}

TEST(CapsuleGeometry, TaylorDeformationOfStretchedEllipsoids) {
  struct Case {
    double s1, s2, s3, theta;
  };
  // The s1 axis at angle theta; the last case has its longest axis along z (not in the shear plane).
  for (const Case& cs : {Case{1.5, 1.0, 1.0, 0.3}, Case{1.6, 0.7, 1.1, -0.45}, Case{1.3, 0.8, 1.6, 1.2},
                         Case{1.25, 0.9, 1.0, 0.0},
                         Case{0.8, 1.4, 1.0, 0.6} /* long axis at 0.6 + pi/2, folded to 0.6 - pi/2 */}) {
    double prev = 1e9;
    for (int level = 1; level <= 4; ++level) {
      CapsuleState s = sphere(level, 2.0, -1.0, 0.5, 1.0);
      double A[3][3];
      const double c[3] = {2.0, -1.0, 0.5};
      ellipsoid_map(cs.s1, cs.s2, cs.s3, cs.theta, A);
      map_nodes(s, A, c);
      const TaylorDeformation d = compute_geometry(s, Backend::Serial).deformation[0];
      const double L = std::max(cs.s1, cs.s2), B = std::min(cs.s1, cs.s2);
      double th = cs.s1 >= cs.s2 ? cs.theta : cs.theta + kPi / 2;
      if (th > kPi / 2) th -= kPi;
      // The polyhedron is A (icosphere); the icosphere's second-moment tensor is isotropic (icosahedral symmetry),
      // so the equivalent-ellipsoid axes are exactly proportional to s_i and D, theta are exact at every level.
      EXPECT_NEAR(d.D, (L - B) / (L + B), 1e-12) << "level " << level;
      EXPECT_NEAR(d.inclination, th, 1e-10) << "level " << level;
      EXPECT_NEAR(d.L / d.B, L / B, 1e-12);
      // The semi-axes themselves converge to the ellipsoid's.
      const double err = std::abs(d.L - L) / L;
      EXPECT_LT(err, 0.3 * prev) << "level " << level;
      prev = err;
    }
    EXPECT_LT(prev, 2e-3);
  }
}

TEST(CapsuleGeometry, MeanVelocityOfLinearFields) {
  for (int level : {0, 2}) {
    CapsuleState s = sphere(level, 1.5, 2.5, -3.5, 1.0);
    const auto d = test::uniform_values(3 * s.x.size(), -0.1, 0.1, 9);
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      s.x[i] += d[3 * i];
      s.y[i] += d[3 * i + 1];
      s.z[i] += d[3 * i + 2];
    }
    const CapsuleGeometry g = compute_geometry(s, Backend::Serial);
    const double* xc = &g.centroid[0];
    const std::size_t n = s.x.size();
    std::vector<double> ux(n), uy(n), uz(n), U, om;

    // Rigid translation.
    const double U0[3] = {0.3, -1.2, 0.7};
    for (std::size_t i = 0; i < n; ++i) {
      ux[i] = U0[0];
      uy[i] = U0[1];
      uz[i] = U0[2];
    }
    compute_mean_velocity(s, Backend::Serial, ux, uy, uz, U, om);
    for (int j = 0; j < 3; ++j) {
      EXPECT_NEAR(U[j], U0[j], 1e-13);
      EXPECT_NEAR(om[j], 0.0, 1e-13);
    }

    // Rigid rotation about the centroid.
    const double w[3] = {0.4, -0.25, 1.1};
    for (std::size_t i = 0; i < n; ++i) {
      const double r[3] = {s.x[i] - xc[0], s.y[i] - xc[1], s.z[i] - xc[2]};
      ux[i] = w[1] * r[2] - w[2] * r[1];
      uy[i] = w[2] * r[0] - w[0] * r[2];
      uz[i] = w[0] * r[1] - w[1] * r[0];
    }
    compute_mean_velocity(s, Backend::Serial, ux, uy, uz, U, om);
    for (int j = 0; j < 3; ++j) {
      EXPECT_NEAR(U[j], 0.0, 1e-13);
      EXPECT_NEAR(om[j], w[j], 1e-13);
    }

    // General traceless linear field u = G x + U0: U = G x_c + U0, omega = axial part of G (exact on polyhedra).
    const double G[3][3] = {{0.2, 0.5, -0.3}, {-0.1, 0.3, 0.8}, {0.6, -0.4, -0.5}};
    for (std::size_t i = 0; i < n; ++i) {
      const double p[3] = {s.x[i], s.y[i], s.z[i]};
      ux[i] = U0[0] + G[0][0] * p[0] + G[0][1] * p[1] + G[0][2] * p[2];
      uy[i] = U0[1] + G[1][0] * p[0] + G[1][1] * p[1] + G[1][2] * p[2];
      uz[i] = U0[2] + G[2][0] * p[0] + G[2][1] * p[1] + G[2][2] * p[2];
    }
    compute_mean_velocity(s, Backend::Serial, ux, uy, uz, U, om);
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(U[j], U0[j] + G[j][0] * xc[0] + G[j][1] * xc[1] + G[j][2] * xc[2], 1e-12);
    EXPECT_NEAR(om[0], 0.5 * (G[2][1] - G[1][2]), 1e-13);
    EXPECT_NEAR(om[1], 0.5 * (G[0][2] - G[2][0]), 1e-13);
    EXPECT_NEAR(om[2], 0.5 * (G[1][0] - G[0][1]), 1e-13);
  }
}

TEST(CapsuleGeometry, NodeNormalsConvergeToSphereNormals) {
  // Level 1 is exact by symmetry (every node's star is symmetric about its radius); from level 2 on the error is
  // O(h).
  double prev = 1e9;
  for (int level = 1; level <= 4; ++level) {
    CapsuleState s = sphere(level, -1.0, 0.5, 2.0, 0.8);
    std::vector<double> nx, ny, nz;
    compute_node_normals(s, Backend::Serial, nx, ny, nz);
    double err = 0.0;
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      const double r[3] = {(s.x[i] + 1.0) / 0.8, (s.y[i] - 0.5) / 0.8, (s.z[i] - 2.0) / 0.8};
      EXPECT_NEAR(nx[i] * nx[i] + ny[i] * ny[i] + nz[i] * nz[i], 1.0, 1e-14);
      err = std::max(err, std::sqrt((nx[i] - r[0]) * (nx[i] - r[0]) + (ny[i] - r[1]) * (ny[i] - r[1]) +
                                    (nz[i] - r[2]) * (nz[i] - r[2])));
    }
    std::printf("level %d: max |n - n_sphere| = %.3e\n", level, err);
    if (level == 1) {
      EXPECT_LT(err, 1e-14);
    } else {
      EXPECT_LT(err, 0.55 * prev);
      EXPECT_LT(err, 0.05);
    }
    prev = level == 1 ? 1e9 : err;
  }
}

TEST(CapsuleGeometry, MinimumEdgeLength) {
  CapsuleState s(2);
  const int sp = s.add_species(0.2);
  s.add_capsule({0, 0, 0}, 1.0, sp);
  s.add_capsule({5, 0, 0}, 0.5, sp);
  s.add_capsule({0, 5, 0}, 2.0, sp);
  const CapsuleGeometry g = compute_geometry(s, Backend::Serial);
  const int nv = s.nodes_per_capsule();
  for (int k = 0; k < 3; ++k) {
    double h = 1e9;
    for (int i = 0; i < nv; ++i)
      for (int j = i + 1; j < nv; ++j) {
        // Brute force over node pairs that share a triangle.
        bool adjacent = false;
        for (int q = s.mesh().nbr_offsets[i]; q < s.mesh().nbr_offsets[i + 1]; ++q) adjacent |= s.mesh().nbr[q] == j;
        if (!adjacent) continue;
        const int a = k * nv + i, b = k * nv + j;
        h = std::min(h, std::hypot(s.x[a] - s.x[b], s.y[a] - s.y[b], s.z[a] - s.z[b]));
      }
    EXPECT_DOUBLE_EQ(g.min_edge[k], h);
  }
  EXPECT_NEAR(g.min_edge[0], 0.276, 0.002);  // docs/method.md §2.1
  EXPECT_DOUBLE_EQ(g.global_min_edge, g.min_edge[1]);
}

// Volume gradient against a central finite difference of the volume; the projection makes the discrete volume
// rate zero and changes u only along w (minimal norm), per capsule.
class VolumeRateTest : public test::OnEachBackend {};

TEST_P(VolumeRateTest, GradientIsDvDxAndProjectionZeroesTheVolumeRate) {
  CapsuleState s(2);
  const int sp = s.add_species(0.2);
  for (int k = 0; k < 5; ++k) s.add_capsule({3.0 * k, 1.5, 0.5 * k}, 1.0, sp);
  const std::size_t n = s.x.size();
  const auto d = test::uniform_values(6 * n, -0.1, 0.1, 11);
  std::vector<double> ux(n), uy(n), uz(n);
  for (std::size_t i = 0; i < n; ++i) {
    s.x[i] += d[6 * i];
    s.y[i] += d[6 * i + 1];
    s.z[i] += d[6 * i + 2];
    ux[i] = d[6 * i + 3] + 0.2 * s.y[i];  // a shear plus noise: a net volume rate per capsule
    uy[i] = d[6 * i + 4] + 0.05 * s.y[i];
    uz[i] = d[6 * i + 5];
  }
  const TriMesh& m = s.mesh();
  const int nc = s.num_capsules(), nv = s.nodes_per_capsule();
  std::vector<double> wx(n), wy(n), wz(n);
  volume_gradient(GetParam(), nc, nv, m.tri.data(), m.inc_offsets.data(), m.inc_tri.data(), s.x.data(), s.y.data(),
                  s.z.data(), wx.data(), wy.data(), wz.data());
  // dV/dx_i by central differences of the exact polyhedron volume (quadratic in each coordinate: exact).
  for (std::size_t i : {std::size_t{0}, std::size_t{77}, std::size_t{200}, n - 1}) {
    const int k = static_cast<int>(i) / nv;
    std::vector<double>* X[3] = {&s.x, &s.y, &s.z};
    const double* W[3] = {wx.data(), wy.data(), wz.data()};
    for (int c = 0; c < 3; ++c) {
      const double h = 1e-4, x0 = (*X[c])[i];
      (*X[c])[i] = x0 + h;
      const double vp = compute_geometry(s, Backend::Serial).volume[k];
      (*X[c])[i] = x0 - h;
      const double vm = compute_geometry(s, Backend::Serial).volume[k];
      (*X[c])[i] = x0;
      EXPECT_NEAR(W[c][i], (vp - vm) / (2 * h), 1e-10) << "node " << i << " component " << c;
    }
  }
  const std::vector<double> u0x = ux, u0y = uy, u0z = uz;
  project_volume_rate(GetParam(), nc, nv, wx.data(), wy.data(), wz.data(), ux.data(), uy.data(), uz.data());
  for (int k = 0; k < nc; ++k) {
    double rate0 = 0.0, rate = 0.0, scale = 0.0;
    double lambda_num = 0.0, lambda_den = 0.0;
    for (std::size_t i = static_cast<std::size_t>(k) * nv; i < static_cast<std::size_t>(k + 1) * nv; ++i) {
      rate0 += wx[i] * u0x[i] + wy[i] * u0y[i] + wz[i] * u0z[i];
      rate += wx[i] * ux[i] + wy[i] * uy[i] + wz[i] * uz[i];
      scale += std::abs(wx[i] * u0x[i]) + std::abs(wy[i] * u0y[i]) + std::abs(wz[i] * u0z[i]);
      // The change is lambda w_i: (u0 - u) x w = 0 node by node.
      const double dx = u0x[i] - ux[i], dy = u0y[i] - uy[i], dz = u0z[i] - uz[i];
      EXPECT_NEAR(dy * wz[i] - dz * wy[i], 0.0, 1e-15);
      EXPECT_NEAR(dz * wx[i] - dx * wz[i], 0.0, 1e-15);
      lambda_num += dx * wx[i] + dy * wy[i] + dz * wz[i];
      lambda_den += wx[i] * wx[i] + wy[i] * wy[i] + wz[i] * wz[i];
    }
    EXPECT_GT(std::abs(rate0), 1e-3) << "the test field has a volume rate to remove";
    EXPECT_LE(std::abs(rate), 1e-15 * scale) << "capsule " << k;
    EXPECT_NEAR(lambda_num / lambda_den, rate0 / lambda_den, 1e-12);
  }
  if (GetParam() != Backend::Serial) {  // the oracle: serial, bit for bit on threads
    std::vector<double> sx(n), sy(n), sz(n), vx = u0x, vy = u0y, vz = u0z;
    volume_gradient(Backend::Serial, nc, nv, m.tri.data(), m.inc_offsets.data(), m.inc_tri.data(), s.x.data(),
                    s.y.data(), s.z.data(), sx.data(), sy.data(), sz.data());
    project_volume_rate(Backend::Serial, nc, nv, sx.data(), sy.data(), sz.data(), vx.data(), vy.data(), vz.data());
    const double tol = GetParam() == Backend::Threads ? 0.0 : 1e-14;
    // Every component of both outputs: the gradient w and the projected velocity u.
    EXPECT_LE(test::max_rel_error(wx, sx), tol);
    EXPECT_LE(test::max_rel_error(wy, sy), tol);
    EXPECT_LE(test::max_rel_error(wz, sz), tol);
    EXPECT_LE(test::max_rel_error(ux, vx), tol);
    EXPECT_LE(test::max_rel_error(uy, vy), tol);
    EXPECT_LE(test::max_rel_error(uz, vz), tol);
  }
}

CAPSFLOW_ON_EACH_BACKEND(VolumeRateTest);

class GeometryBackendTest : public test::OnEachBackend {};

TEST_P(GeometryBackendTest, MatchesSerial) {
  CapsuleState s(2);
  const int sp = s.add_species(0.2);
  for (int k = 0; k < 40; ++k) s.add_capsule({2.5 * (k % 8), 2.5 * (k / 8), 0.3 * k}, 1.0, sp);
  const auto d = test::uniform_values(6 * s.x.size(), -0.1, 0.1, 3);
  const std::size_t n = s.x.size();
  std::vector<double> ux(n), uy(n), uz(n);
  for (std::size_t i = 0; i < n; ++i) {
    s.x[i] += d[6 * i];
    s.y[i] += d[6 * i + 1];
    s.z[i] += d[6 * i + 2];
    ux[i] = d[6 * i + 3];
    uy[i] = d[6 * i + 4] + 0.5 * s.y[i];
    uz[i] = d[6 * i + 5] - 0.3 * s.x[i];
  }
  const double tol = GetParam() == Backend::Threads ? 0.0 : 1e-14;
  const CapsuleGeometry a = compute_geometry(s, Backend::Serial), b = compute_geometry(s, GetParam());
  EXPECT_LE(test::max_rel_error(b.volume, a.volume), tol);
  EXPECT_LE(test::max_rel_error(b.area, a.area), tol);
  EXPECT_LE(test::max_rel_error(b.centroid, a.centroid), tol);
  EXPECT_LE(test::max_rel_error(b.moments, a.moments), tol);
  EXPECT_LE(test::max_rel_error(b.min_edge, a.min_edge), tol);
  std::vector<double> U1, w1, U2, w2;
  compute_mean_velocity(s, Backend::Serial, ux, uy, uz, U1, w1);
  compute_mean_velocity(s, GetParam(), ux, uy, uz, U2, w2);
  EXPECT_LE(test::max_rel_error(U2, U1), tol);
  EXPECT_LE(test::max_rel_error(w2, w1), tol);
  std::vector<double> n1[3], n2[3];
  compute_node_normals(s, Backend::Serial, n1[0], n1[1], n1[2]);
  compute_node_normals(s, GetParam(), n2[0], n2[1], n2[2]);
  for (int j = 0; j < 3; ++j) EXPECT_LE(test::max_rel_error(n2[j], n1[j]), tol);
}

CAPSFLOW_ON_PARALLEL_BACKENDS(GeometryBackendTest);
