// Exact slab volumes of triangulated capsules (docs/analysis.md §7; issue 9): V_below against closed forms
// (cube, tetrahedron, spherical cap), the sum of the slabs against the mesh volume, translation, planes through
// vertices and faces.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "host/state/icosphere.hpp"
#include "kernels/slab_volume.hpp"

using namespace capsflow;

namespace {

constexpr double kPi = 3.14159265358979323846;

struct Mesh {
  std::vector<double> x, y, z;
  std::vector<int> tri;
  int nv() const { return static_cast<int>(x.size()); }
  int ntri() const { return static_cast<int>(tri.size() / 3); }
};

// Icosphere of the given level, radius r, centre (cx, cy, cz).
Mesh sphere(int level, double r, double cx, double cy, double cz) {
  const TriMesh& m = icosphere(level);
  Mesh s;
  for (int i = 0; i < m.num_nodes(); ++i) {
    s.x.push_back(cx + r * m.x[i]);
    s.y.push_back(cy + r * m.y[i]);
    s.z.push_back(cz + r * m.z[i]);
  }
  s.tri = m.tri;
  return s;
}

// Axis-aligned box [x0, x0 + a] x [y0, y0 + b] x [z0, z0 + c], 12 outward triangles.
Mesh box(double x0, double y0, double z0, double a, double b, double c) {
  Mesh m;
  for (int i = 0; i < 8; ++i) {
    m.x.push_back(x0 + ((i & 1) ? a : 0.0));
    m.y.push_back(y0 + ((i & 2) ? b : 0.0));
    m.z.push_back(z0 + ((i & 4) ? c : 0.0));
  }
  // Faces as quads (corner bits: 1 = x, 2 = y, 4 = z), counter-clockwise from outside.
  const int quads[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
  for (const auto& q : quads) {
    m.tri.insert(m.tri.end(), {q[0], q[1], q[2], q[0], q[2], q[3]});
  }
  return m;
}

// Volume by tetrahedra from an arbitrary apex: independent of the divergence-theorem form in the kernel.
double mesh_volume(const Mesh& m) {
  const double q[3] = {0.3, -2.0, 1.7};
  double v = 0.0;
  for (int t = 0; t < m.ntri(); ++t) {
    double p[3][3];
    for (int c = 0; c < 3; ++c) {
      const int i = m.tri[3 * t + c];
      p[c][0] = m.x[i] - q[0];
      p[c][1] = m.y[i] - q[1];
      p[c][2] = m.z[i] - q[2];
    }
    v += (p[0][0] * (p[1][1] * p[2][2] - p[1][2] * p[2][1]) - p[0][1] * (p[1][0] * p[2][2] - p[1][2] * p[2][0]) +
          p[0][2] * (p[1][0] * p[2][1] - p[1][1] * p[2][0])) /
         6.0;
  }
  return v;
}

double below(const Mesh& m, double c) { return capsule_volume_below(m.ntri(), m.tri.data(), m.x.data(), m.y.data(), m.z.data(), c); }

std::vector<double> slabs(const Mesh& m, double H, int nbins) {
  std::vector<double> out(static_cast<std::size_t>(nbins), 0.0);
  capsule_slab_volumes(m.nv(), m.ntri(), m.tri.data(), m.x.data(), m.y.data(), m.z.data(), H, nbins, out.data());
  return out;
}

}  // namespace

TEST(SlabVolume, BoxBelowPlaneIsLinearIncludingPlanesThroughFaces) {
  // Faces at y = 0.5 and y = 1.5 lie exactly on cut planes there; vertices are on the plane too.
  const Mesh m = box(0.25, 0.5, -1.0, 2.0, 1.0, 3.0);
  ASSERT_NEAR(mesh_volume(m), 6.0, 1e-13);
  for (double c : {-1.0, 0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 10.0}) {
    const double expect = 6.0 * std::min(std::max(c - 0.5, 0.0), 1.0);
    EXPECT_NEAR(below(m, c), expect, 1e-13) << "c = " << c;
  }
  // Slabs of width 0.25 over [0, 2]: the box fills slabs 2..5 exactly.
  const auto s = slabs(m, 2.0, 8);
  for (int j = 0; j < 8; ++j) EXPECT_NEAR(s[j], (j >= 2 && j <= 5) ? 1.5 : 0.0, 1e-13) << "slab " << j;
}

TEST(SlabVolume, TetrahedronMatchesClosedFormCut) {
  // Vertices (0,0,0), (1,0,0), (0,1,0), (0,0,1): the part with y > c is a similar tetrahedron of side 1 - c, so
  // V_below(c) = (1 - (1 - c)^3) / 6. Faces are not axis-aligned.
  Mesh m;
  m.x = {0, 1, 0, 0};
  m.y = {0, 0, 1, 0};
  m.z = {0, 0, 0, 1};
  m.tri = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  ASSERT_NEAR(mesh_volume(m), 1.0 / 6.0, 1e-15);
  for (double c : {0.0, 0.1, 0.3, 0.5, 0.77, 1.0}) {
    EXPECT_NEAR(below(m, c), (1.0 - std::pow(1.0 - c, 3)) / 6.0, 1e-15) << "c = " << c;
  }
}

TEST(SlabVolume, SumOfSlabsEqualsMeshVolumeOfDeformedCapsule) {
  // A perturbed, stretched level-2 capsule (320 triangles, the production mesh) inside a slit of height 10.155.
  Mesh m = sphere(2, 1.0, 3.3, 4.1, -0.7);
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> u(-0.05, 0.05);
  for (int i = 0; i < m.nv(); ++i) {
    m.x[i] = 3.3 + 1.3 * (m.x[i] - 3.3) + u(rng);
    m.y[i] = 4.1 + 0.8 * (m.y[i] - 4.1) + 0.3 * (m.x[i] - 3.3) + u(rng);
    m.z[i] += u(rng);
  }
  const double V = mesh_volume(m);
  for (int nbins : {1, 7, 50, 100, 1000}) {
    const auto s = slabs(m, 10.155, nbins);
    double sum = 0.0;
    int touched = 0;
    for (double v : s) {
      sum += v;
      touched += v != 0.0;
      EXPECT_GE(v, -1e-14);
    }
    EXPECT_NEAR(sum, V, 1e-12 * V) << nbins << " bins";
    EXPECT_LE(touched, static_cast<int>(2.0 / (10.155 / nbins)) + 2);  // only the spanned slabs are written
  }
  // Far planes: nothing below, and everything (the polyhedron's own volume).
  EXPECT_EQ(below(m, -5.0), 0.0);
  EXPECT_NEAR(below(m, 50.0), V, 1e-12 * V);
}

TEST(SlabVolume, SlabsAreAddedNotOverwritten) {
  const Mesh m = box(0.0, 1.0, 0.0, 1.0, 1.0, 1.0);
  std::vector<double> out(4, 0.5);
  capsule_slab_volumes(m.nv(), m.ntri(), m.tri.data(), m.x.data(), m.y.data(), m.z.data(), 4.0, 4, out.data());
  EXPECT_NEAR(out[0], 0.5, 1e-15);
  EXPECT_NEAR(out[1], 1.5, 1e-15);
  EXPECT_NEAR(out[2], 0.5, 1e-15);
  EXPECT_NEAR(out[3], 0.5, 1e-15);
}

TEST(SlabVolume, Level4IcosphereAgainstSphericalCap) {
  const double r = 1.0, yc = 5.0;
  const Mesh m = sphere(4, r, 0.4, yc, -2.0);
  const double Vpoly = mesh_volume(m);
  EXPECT_NEAR(below(m, yc - 2.0 * r), 0.0, 1e-15);
  EXPECT_NEAR(below(m, yc + 2.0 * r), Vpoly, 1e-12 * Vpoly);
  // Cap fraction V_cap(h) / V_sphere with h = c - (yc - r); the inscribed polyhedron agrees to its discretisation.
  for (double c : {4.5, 5.0, 5.3, 5.9, 4.05}) {
    const double h = c - (yc - r);
    const double cap = kPi * h * h * (3.0 * r - h) / 3.0 / (4.0 / 3.0 * kPi * r * r * r);
    EXPECT_NEAR(below(m, c) / Vpoly, cap, 1e-3) << "c = " << c;
  }
  // Symmetry about the equator: V_below(yc) is half the polyhedron (the icosphere is centrally symmetric).
  EXPECT_NEAR(below(m, yc), 0.5 * Vpoly, 1e-12);
}

TEST(SlabVolume, TranslatedCapsuleGivesShiftedSlabs) {
  // Shift by exactly 3 slabs of width 0.25 (binary-exact): slab j moves to slab j + 3.
  const Mesh a = sphere(3, 1.0, 0.0, 2.1, 0.0);
  Mesh b = a;
  for (double& y : b.y) y += 0.75;
  const auto sa = slabs(a, 8.0, 32), sb = slabs(b, 8.0, 32);
  for (int j = 0; j < 32; ++j) {
    const double expect = j >= 3 ? sa[j - 3] : 0.0;
    EXPECT_NEAR(sb[j], expect, 1e-13) << "slab " << j;
  }
}

TEST(SlabVolume, PlaneThroughVertexIsContinuous) {
  // Level-0 icosahedron rotated so that a vertex sits exactly on plane y = 3 (the top pole at y = 2 + 1) and
  // another on y = 1; the cut there must equal the limits from either side.
  const TriMesh& ico = icosphere(0);
  // Rotate vertex 0 onto +y: find the rotation about the axis (v0 x ey).
  const double v0[3] = {ico.x[0], ico.y[0], ico.z[0]};
  const double ax[3] = {v0[2], 0.0, -v0[0]};  // v0 x (0,1,0)
  const double s = std::sqrt(ax[0] * ax[0] + ax[2] * ax[2]), cth = v0[1];
  Mesh m;
  for (int i = 0; i < ico.num_nodes(); ++i) {
    const double p[3] = {ico.x[i], ico.y[i], ico.z[i]};
    double q[3] = {p[0], p[1], p[2]};
    if (s > 0) {
      const double k[3] = {ax[0] / s, 0.0, ax[2] / s};
      const double kxp[3] = {k[1] * p[2] - k[2] * p[1], k[2] * p[0] - k[0] * p[2], k[0] * p[1] - k[1] * p[0]};
      const double kp = k[0] * p[0] + k[1] * p[1] + k[2] * p[2];
      for (int d = 0; d < 3; ++d) q[d] = p[d] * cth + kxp[d] * s + k[d] * kp * (1 - cth);
    }
    m.x.push_back(q[0]);
    m.y.push_back(q[1] + 2.0);
    m.z.push_back(q[2]);
  }
  m.tri = ico.tri;
  int on_plane = 0;
  for (double y : m.y) on_plane += std::abs(y - 3.0) < 1e-12;
  ASSERT_EQ(on_plane, 1);
  m.y[static_cast<std::size_t>(std::max_element(m.y.begin(), m.y.end()) - m.y.begin())] = 3.0;  // exactly
  const double V = mesh_volume(m);
  EXPECT_NEAR(below(m, 3.0), V, 1e-14);
  EXPECT_NEAR(below(m, 3.0 - 1e-9), V, 1e-12);
  // A plane through the 5 upper-ring vertices' neighbourhood: compare the exact cut at a vertex height with
  // the average of two close planes around it.
  const double yv = m.y[3];
  const double mid = below(m, yv), lo = below(m, yv - 1e-7), hi = below(m, yv + 1e-7);
  EXPECT_NEAR(mid, 0.5 * (lo + hi), 1e-12);
  // And slabs with an edge exactly at the top vertex still sum to the volume.
  const auto sl = slabs(m, 6.0, 6);  // edges at integers: the vertex y = 3 and the bottom vertex y = 1
  double sum = 0.0;
  for (double v : sl) sum += v;
  EXPECT_NEAR(sum, V, 1e-13);
}

TEST(SlabVolume, SpeciesSlabsAccumulateCapsulesIntoTheirSlots) {
  // Three unit boxes sharing one 12-triangle mesh: capsules 0 and 2 in slot 1, capsule 1 in slot 0.
  const Mesh a = box(0.0, 0.0, 0.0, 1.0, 1.0, 1.0), b = box(0.0, 2.0, 0.0, 1.0, 1.0, 1.0), c = box(0.0, 0.5, 0.0, 1.0, 1.0, 1.0);
  Mesh all;
  for (const Mesh* m : {&a, &b, &c}) {
    all.x.insert(all.x.end(), m->x.begin(), m->x.end());
    all.y.insert(all.y.end(), m->y.begin(), m->y.end());
    all.z.insert(all.z.end(), m->z.begin(), m->z.end());
  }
  const int slot[3] = {1, 0, 1};
  std::vector<double> out(2 * 4, 0.0);  // 2 slots x 4 slabs of width 1 over [0, 4]
  species_slab_volumes(3, 8, a.ntri(), a.tri.data(), all.x.data(), all.y.data(), all.z.data(), slot, 4.0, 4, out.data());
  const std::vector<double> expect = {0.0, 0.0, 1.0, 0.0, /* slot 1: */ 1.5, 0.5, 0.0, 0.0};
  for (std::size_t j = 0; j < out.size(); ++j) EXPECT_NEAR(out[j], expect[j], 1e-15) << j;
  std::vector<double> below(3);
  capsules_volume_below(3, 8, a.ntri(), a.tri.data(), all.x.data(), all.y.data(), all.z.data(), 1.25, below.data());
  EXPECT_NEAR(below[0], 1.0, 1e-15);
  EXPECT_NEAR(below[1], 0.0, 1e-15);
  EXPECT_NEAR(below[2], 0.75, 1e-15);
}
