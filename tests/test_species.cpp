// Per-species size, shape, membrane law and orientation (issue 23): the [[species]] and [[capsule]] keys, the
// capsule state's per-capsule laws and shapes, placement of mixed sizes with random orientations, the step rule's
// law and size factors, and a mixed-size suspension that runs, restarts bit for bit and analyses.
#include <gtest/gtest.h>

#include <cmath>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "host/analysis/analysis.hpp"
#include "host/base/errors.hpp"
#include "host/base/h5_file.hpp"
#include "host/physics/config.hpp"
#include "host/physics/initial_conditions.hpp"
#include "host/physics/simulation.hpp"
#include "host/run/run_driver.hpp"
#include "host/state/capsule_state.hpp"
#include "host/state/shapes.hpp"
#include "support/cli_runner.hpp"
#include "support/run_files.hpp"
#include "support/temp_dir.hpp"

namespace {

using namespace capsflow;
namespace fs = std::filesystem;

constexpr double kPi = 3.14159265358979323846;

// A slit with room for capsules of bounding radius up to 1.4 and a cutoff of 0.875.
std::string box(double L = 9.0, double H = 8.0) {
  std::ostringstream o;
  o << "[domain]\nH = " << H << "\nLx = " << L << "\nLz = " << L << "\n[ggem]\nalpha = 4.0\nalpha_hm = 0.5\n"
    << "[run]\nbackend = \"threads\"\n[flow]\ntype = \"shear\"\n[capsules]\nmesh_level = 1\n";
  return o.str();
}

std::string message_of(const std::string& text) {
  try {
    parse_config(text, "t.toml");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(SpeciesKeys, AbsentKeysTakeTheCapsulesDefaults) {
  const Config c = parse_config(box() + "inflation = 0.05\nradius = 1.0\nlaw = \"skalak\"\nskalak_c = 3\n"
                                        "[[species]]\nname = \"a\"\nca = 0.2\n"
                                        "[[species]]\nname = \"b\"\nca = 0.4\nradius = 0.5\nshape = \"spheroid\"\n"
                                        "aspect = 0.4\nlaw = \"neo-hookean\"\ninflation = 0\n"
                                        "[[species]]\nname = \"c\"\nca = 0.4\nshape = \"biconcave\"\nskalak_c = 10\n",
                                "t.toml");
  ASSERT_EQ(c.species.size(), 3u);
  EXPECT_EQ(c.species_radius(0), 1.0);
  EXPECT_EQ(c.species_radius(1), 0.5);
  EXPECT_EQ(c.species_membrane(0).law, MembraneLaw::Skalak);
  EXPECT_EQ(c.species_membrane(0).skalak_C, 3.0);
  EXPECT_EQ(c.species_membrane(0).inflation, 0.05);
  EXPECT_EQ(c.species_membrane(1).law, MembraneLaw::NeoHookean);
  EXPECT_EQ(c.species_membrane(1).inflation, 0.0);
  EXPECT_EQ(c.species_membrane(2).skalak_C, 10.0);
  EXPECT_EQ(c.species[0].shape.kind, ShapeKind::Sphere);
  EXPECT_EQ(c.species[1].shape.kind, ShapeKind::Spheroid);
  EXPECT_EQ(c.species[1].shape.aspect, 0.4);
  EXPECT_EQ(c.species[2].shape.kind, ShapeKind::Biconcave);
  // Bounding radii: the sphere's radius, the oblate spheroid's equator b = a / aspect^(1/3), the disc's R0.
  EXPECT_EQ(c.species_bounding_radius(0), 1.0);
  EXPECT_NEAR(c.species_bounding_radius(1), 0.5 / std::cbrt(0.4), 1e-15);
  EXPECT_NEAR(c.species_bounding_radius(2), 1.385738, 1e-6);
  EXPECT_EQ(c.max_bounding_radius(), c.species_bounding_radius(2));

  // The resolved configuration reads back to the same values; keys not given stay out of it.
  const std::string t = to_toml(c);
  const Config d = parse_config(t, "echo");
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(d.species_radius(i), c.species_radius(i));
    EXPECT_EQ(d.species[i].shape.kind, c.species[i].shape.kind);
    EXPECT_EQ(d.species[i].shape.aspect, c.species[i].shape.aspect);
    EXPECT_EQ(d.species_membrane(i).law, c.species_membrane(i).law);
    EXPECT_EQ(d.species_membrane(i).skalak_C, c.species_membrane(i).skalak_C);
    EXPECT_EQ(d.species_membrane(i).inflation, c.species_membrane(i).inflation);
  }
  EXPECT_FALSE(d.species[0].radius.has_value());
  EXPECT_FALSE(d.species[0].law.has_value());
}

TEST(SpeciesKeys, BadValuesNameTheKey) {
  const std::string sp = box() + "[[species]]\nname = \"a\"\nca = 0.2\n";
  EXPECT_NE(message_of(sp + "aspect = 2\n").find("[[species]] 1 aspect: expected no aspect unless shape = \"spheroid\""),
            std::string::npos);
  EXPECT_NE(message_of(sp + "shape = \"spheroid\"\n").find("[[species]] 1 aspect: expected a finite number > 0"),
            std::string::npos);
  EXPECT_NE(message_of(sp + "shape = \"cube\"\n").find("[[species]] 1 shape: expected one of \"sphere\""),
            std::string::npos);
  EXPECT_NE(message_of(sp + "radius = -1\n").find("[[species]] 1 radius: expected a finite number > 0"),
            std::string::npos);
  EXPECT_NE(message_of(sp + "law = \"hooke\"\n").find("[[species]] 1 law: expected one of"), std::string::npos);
  EXPECT_NE(message_of(sp + "skalak_c = 0\n").find("[[species]] 1 skalak_c: expected a finite number > 0"),
            std::string::npos);
  EXPECT_NE(message_of(sp + "inflation = -0.1\n").find("[[species]] 1 inflation: expected a finite number >= 0"),
            std::string::npos);
  EXPECT_NE(message_of(sp + "[[capsule]]\nspecies = \"a\"\ncenter = [4, 4, 4]\norientation = [0, 0, 0]\n")
                .find("[[capsule]] 1 orientation: expected a non-zero axis"),
            std::string::npos);
}

// The checks that need room use each species' bounding sphere.
TEST(SpeciesKeys, WallsBoxAndOverlapUseTheBoundingRadii) {
  const std::string two = "[[species]]\nname = \"big\"\nca = 0.2\nradius = 1.2\n"
                          "[[species]]\nname = \"small\"\nca = 0.2\nradius = 0.5\n[time]\nend = 1\n";
  // 1.2 + 0.5 + 0.02 = 1.72 apart is allowed, 1.70 is not.
  EXPECT_NO_THROW(validate_run_config(parse_config(
      box() + two + "[[capsule]]\nspecies = \"big\"\ncenter = [3, 4, 4]\n[[capsule]]\nspecies = \"small\"\n"
                    "center = [4.72, 4, 4]\n",
      "t.toml")));
  std::string m = message_of(box() + two + "[[capsule]]\nspecies = \"big\"\ncenter = [3, 4, 4]\n[[capsule]]\n"
                                           "species = \"small\"\ncenter = [4.70, 4, 4]\n");
  EXPECT_NE(m.find("capsule 2 overlaps capsule 1"), std::string::npos) << m;
  EXPECT_NE(m.find("r_i + r_j (bounding radii) + min_gap = 1.72"), std::string::npos) << m;
  // The small capsule may sit closer to the wall than the big one.
  EXPECT_NO_THROW(validate_run_config(
      parse_config(box() + two + "[[capsule]]\nspecies = \"small\"\ncenter = [3, 0.52, 4]\n", "t.toml")));
  m = message_of(box() + two + "[[capsule]]\nspecies = \"big\"\ncenter = [3, 0.52, 4]\n");
  EXPECT_NE(m.find("[[capsule]] 1 center: capsule 1 at y = 0.52 crosses the wall"), std::string::npos) << m;
  // A red cell's rim (R0 = 1.386 a) decides the box: Lx >= 2 (cutoff + 2 R0).
  m = message_of(box(7.2) + "[[species]]\nname = \"rbc\"\nca = 0.2\nshape = \"biconcave\"\n[suspension]\ncount = 1\n");
  EXPECT_NE(m.find("[domain] Lx: Lx = 7.2 is too small for capsules of bounding radius 1.385"), std::string::npos)
      << m;
}

TEST(SpeciesShapes, RotationToAxisTurnsBodyZOntoTheAxis) {
  for (const std::array<double, 3>& n : std::vector<std::array<double, 3>>{
           {0, 0, 1}, {0, 0, -2}, {1, 0, 0}, {0, 3, 0}, {1, -2, 0.5}, {-0.3, 0.1, -4}}) {
    const Rotation R = rotation_to_axis(n);
    const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(R[3 * i + 2], n[i] / len, 1e-15);  // R e_z = n / |n|
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        double d = 0.0;
        for (int k = 0; k < 3; ++k) d += R[3 * i + k] * R[3 * j + k];
        EXPECT_NEAR(d, i == j ? 1.0 : 0.0, 1e-15);
      }
  }
  EXPECT_EQ(rotation_to_axis({0, 0, 5}), kIdentityRotation);
  EXPECT_THROW(rotation_to_axis({0, 0, 0}), InputError);
}

// Shoemake's construction is uniform on SO(3): a turned axis is uniform on the sphere, so its second moments are I/3
// and its mean is 0 (each within 5 standard errors of 4000 samples).
TEST(SpeciesShapes, UniformRotationsAreRotationsWithAnIsotropicAxis) {
  std::mt19937_64 rng(7);
  auto u = [&] { return static_cast<double>(rng() >> 11) * 0x1.0p-53; };
  const int n = 4000;
  double m[3] = {0, 0, 0}, M[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
  for (int s = 0; s < n; ++s) {
    const double u1 = u(), u2 = u();
    const Rotation R = uniform_rotation(u1, u2, u());
    const double det = R[0] * (R[4] * R[8] - R[5] * R[7]) - R[1] * (R[3] * R[8] - R[5] * R[6]) +
                       R[2] * (R[3] * R[7] - R[4] * R[6]);
    ASSERT_NEAR(det, 1.0, 1e-13);
    const double a[3] = {R[2], R[5], R[8]};
    for (int i = 0; i < 3; ++i) {
      m[i] += a[i] / n;
      for (int j = 0; j < 3; ++j) M[i][j] += a[i] * a[j] / n;
    }
  }
  // Var(a_i) = 1/3, Var(a_i^2) = 1/5 - 1/9, Var(a_i a_j) = 1/15.
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(m[i], 0.0, 5 * std::sqrt(1.0 / 3.0 / n));
    for (int j = 0; j < 3; ++j)
      EXPECT_NEAR(M[i][j], i == j ? 1.0 / 3.0 : 0.0, 5 * std::sqrt((i == j ? 0.2 - 1.0 / 9.0 : 1.0 / 15.0) / n));
  }
}

SpeciesProperties props(ShapeKind kind, MembraneLaw law, double C = 1.0, double beta = 0.0, double aspect = 1.0) {
  SpeciesProperties p;
  p.Ca = 0.3;
  p.membrane = {law, C, beta};
  p.shape = {kind, aspect};
  return p;
}

double max_abs(const std::vector<double>& v) {
  double m = 0.0;
  for (double x : v) m = std::max(m, std::abs(x));
  return m;
}

// With inflation 0 the initial shape is the stress-free one: no in-plane force, whatever the shape, law, size and
// orientation.
TEST(SpeciesState, EveryShapeStartsStressFreeWithoutInflation) {
  for (ShapeKind kind : {ShapeKind::Sphere, ShapeKind::Spheroid, ShapeKind::Biconcave})
    for (MembraneLaw law : {MembraneLaw::NeoHookean, MembraneLaw::Skalak}) {
      CapsuleState s(2);
      const int sp = s.add_species(props(kind, law, 10.0, 0.0, kind == ShapeKind::Spheroid ? 2.0 : 1.0));
      s.add_capsule({3, 4, 5}, 0.7, sp, rotation_to_axis({1, 2, 3}));
      s.compute_membrane_forces(Backend::Serial);
      EXPECT_LT(max_abs(s.fx), 1e-12) << static_cast<int>(kind);
      EXPECT_LT(max_abs(s.fy), 1e-12);
      EXPECT_LT(max_abs(s.fz), 1e-12);
    }
}

// A biconcave capsule encloses (4/3) pi a^3 at its radius (to the mesh's error, level 3: 1.3 %), and its bending
// rigidity uses its own radius: kappa = kb Gs a^2, Gs = a / Ca.
TEST(SpeciesState, ShapesTakeTheirRadiusAndOrientation) {
  CapsuleState s(3);
  SpeciesProperties p = props(ShapeKind::Biconcave, MembraneLaw::Skalak, 10.0);
  p.bending_modulus = 0.02;
  const int sp = s.add_species(p);
  s.add_capsule({5, 5, 5}, 2.0, sp, rotation_to_axis({1, 0, 0}));
  const CapsuleGeometry g = compute_geometry(s, Backend::Serial);
  EXPECT_NEAR(g.volume[0] / (4.0 / 3.0 * kPi * 8.0), 1.0, 0.015);
  EXPECT_NEAR(s.bending_rigidity()[0], 0.02 * (2.0 / 0.3) * 4.0, 1e-14);
  // The disc's axis is x: its thickness is along x (the smallest second moment), its rim in y-z.
  const double* m = &g.moments[0];  // xx, yy, zz, xy, xz, yz
  EXPECT_LT(m[0], 0.3 * m[1]);
  EXPECT_NEAR(m[1] / m[2], 1.0, 0.02);
}

// Per-capsule laws: two capsules of different laws in one state get the forces each gets alone, bit for bit, on
// every host backend.
TEST(SpeciesState, MixedLawsGiveEachCapsuleItsOwnForces) {
  auto deformed = [](CapsuleState& s) {
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      s.x[i] *= 1.0 + 0.05 * std::sin(3.0 * s.y[i]);
      s.z[i] *= 0.97;
    }
  };
  const SpeciesProperties nh = props(ShapeKind::Sphere, MembraneLaw::NeoHookean, 1.0, 0.1);
  const SpeciesProperties sk = props(ShapeKind::Spheroid, MembraneLaw::Skalak, 10.0, 0.0, 0.5);
  for (Backend b : {Backend::Serial, Backend::Threads}) {
    CapsuleState both(2), a(2), c(2);
    const int s0 = both.add_species(nh), s1 = both.add_species(sk);
    both.add_capsule({2, 3, 4}, 1.0, s0);
    both.add_capsule({6, 3, 4}, 0.8, s1, rotation_to_axis({0, 1, 1}));
    a.add_capsule({2, 3, 4}, 1.0, a.add_species(nh));
    c.add_capsule({6, 3, 4}, 0.8, c.add_species(sk), rotation_to_axis({0, 1, 1}));
    deformed(both);
    deformed(a);
    deformed(c);
    both.compute_membrane_forces(b);
    a.compute_membrane_forces(b);
    c.compute_membrane_forces(b);
    const std::size_t nv = a.x.size();
    for (std::size_t i = 0; i < nv; ++i) {
      ASSERT_EQ(both.fx[i], a.fx[i]);
      ASSERT_EQ(both.fy[nv + i], c.fy[i]);
      ASSERT_EQ(both.fz[nv + i], c.fz[i]);
    }
    const std::vector<double> e = both.membrane_energy();
    EXPECT_EQ(e[0], a.membrane_energy()[0]);
    EXPECT_EQ(e[1], c.membrane_energy()[0]);
  }
}

// The elastic problem is frame-indifferent: a turned capsule deformed by the turned displacement field has the turned
// forces.
TEST(SpeciesState, ATurnedCapsuleHasTheTurnedForces) {
  const Rotation R = rotation_to_axis({0.3, -1.0, 0.6});
  CapsuleState a(2), b(2);
  const SpeciesProperties p = props(ShapeKind::Biconcave, MembraneLaw::Skalak, 5.0);
  a.add_capsule({0, 0, 0}, 1.0, a.add_species(p));
  b.add_capsule({0, 0, 0}, 1.0, b.add_species(p), R);
  for (std::size_t i = 0; i < a.x.size(); ++i) {
    const double dx = 0.1 * a.x[i] * a.z[i], dy = -0.05 * a.y[i], dz = 0.02 * a.x[i];
    a.x[i] += dx;
    a.y[i] += dy;
    a.z[i] += dz;
    b.x[i] += R[0] * dx + R[1] * dy + R[2] * dz;
    b.y[i] += R[3] * dx + R[4] * dy + R[5] * dz;
    b.z[i] += R[6] * dx + R[7] * dy + R[8] * dz;
  }
  a.compute_membrane_forces(Backend::Serial);
  b.compute_membrane_forces(Backend::Serial);
  const double scale = max_abs(a.Fx) + max_abs(a.Fy) + max_abs(a.Fz);
  ASSERT_GT(scale, 1e-3);
  for (std::size_t i = 0; i < a.x.size(); ++i) {
    EXPECT_NEAR(b.Fx[i], R[0] * a.Fx[i] + R[1] * a.Fy[i] + R[2] * a.Fz[i], 1e-12 * scale);
    EXPECT_NEAR(b.Fy[i], R[3] * a.Fx[i] + R[4] * a.Fy[i] + R[5] * a.Fz[i], 1e-12 * scale);
    EXPECT_NEAR(b.Fz[i], R[6] * a.Fx[i] + R[7] * a.Fy[i] + R[8] * a.Fz[i], 1e-12 * scale);
  }
}

TEST(SpeciesState, BadSpeciesAndOrientationsAreRefused) {
  CapsuleState s(1);
  EXPECT_THROW(s.add_species(props(ShapeKind::Sphere, MembraneLaw::Skalak, 0.0)), InputError);
  EXPECT_THROW(s.add_species(props(ShapeKind::Sphere, MembraneLaw::NeoHookean, 1.0, -0.1)), InputError);
  EXPECT_THROW(s.add_species(props(ShapeKind::Spheroid, MembraneLaw::NeoHookean, 1.0, 0.0, -1.0)), InputError);
  const int sp = s.add_species(props(ShapeKind::Sphere, MembraneLaw::NeoHookean));
  EXPECT_THROW(s.add_capsule({0, 0, 0}, 1.0, sp, Rotation{1, 0, 0, 0, 1, 0, 0, 0, -1}), InputError);  // reflection
  EXPECT_THROW(s.add_capsule({0, 0, 0}, 1.0, sp, Rotation{2, 0, 0, 0, 1, 0, 0, 0, 1}), InputError);
  EXPECT_EQ(s.num_capsules(), 0);
}

std::string mixed_suspension(int seed = 3) {
  return box(9.0, 8.0) + "[[species]]\nname = \"cells\"\nca = 0.3\nshape = \"biconcave\"\nlaw = \"skalak\"\n"
                         "skalak_c = 5\ninflation = 0\nbending_modulus = 0.02\n"
                         "[[species]]\nname = \"platelets\"\nca = 0.05\nradius = 0.55\nshape = \"spheroid\"\n"
                         "aspect = 0.4\n"
                         "[suspension]\nvolume_fraction = 0.12\nfractions = [0.7, 0.3]\nseed = " +
         std::to_string(seed) + "\n[time]\nend = 0.12\n[output]\nevery = 0.02\nframes_every = 0.06\n"
                                "checkpoint_every = 0.06\n";
}

// Generalised winding number of a closed triangulated surface about p (1 inside, 0 outside): the solid angles of its
// triangles (Van Oosterom & Strackee 1983) over 4 pi. Independent of the shapes' implicit tests placement uses.
double winding_number(const CapsuleState& s, int k, double px, double py, double pz) {
  const int nv = s.nodes_per_capsule();
  const std::vector<int>& tri = s.mesh().tri;
  double sum = 0.0;
  for (std::size_t t = 0; t < tri.size() / 3; ++t) {
    double v[3][3], len[3];
    for (int c = 0; c < 3; ++c) {
      const std::size_t i = static_cast<std::size_t>(k) * nv + tri[3 * t + c];
      v[c][0] = s.x[i] - px;
      v[c][1] = s.y[i] - py;
      v[c][2] = s.z[i] - pz;
      len[c] = std::sqrt(v[c][0] * v[c][0] + v[c][1] * v[c][1] + v[c][2] * v[c][2]);
    }
    const double det = v[0][0] * (v[1][1] * v[2][2] - v[1][2] * v[2][1]) -
                       v[0][1] * (v[1][0] * v[2][2] - v[1][2] * v[2][0]) +
                       v[0][2] * (v[1][0] * v[2][1] - v[1][1] * v[2][0]);
    auto dot = [&](int a, int b) { return v[a][0] * v[b][0] + v[a][1] * v[b][1] + v[a][2] * v[b][2]; };
    const double den = len[0] * len[1] * len[2] + dot(0, 1) * len[2] + dot(0, 2) * len[1] + dot(1, 2) * len[0];
    sum += 2.0 * std::atan2(det, den);
  }
  return sum / (4.0 * kPi);
}

// Random sequential placement of red cells and platelets at random orientations: no node of a capsule inside another
// (winding number), every node between the walls, the count from the mean volume, every turned shape turned, and
// pairs closer than their bounding spheres would allow (the shapes' own test is what lets red cells pack).
TEST(SpeciesPlacement, TurnedShapesDoNotOverlapAndStayBetweenTheWalls) {
  const Config c = parse_config(mixed_suspension(), "t.toml");
  const std::vector<CapsulePlacement> p = place_capsules(c);
  const double vmean = 0.7 * 4.0 / 3.0 * kPi + 0.3 * 4.0 / 3.0 * kPi * std::pow(0.55, 3);
  EXPECT_EQ(static_cast<long>(p.size()), std::lround(0.12 * 8.0 * 81.0 / vmean));
  CapsuleState s(2);
  for (std::size_t k = 0; k < c.species.size(); ++k)
    s.add_species(SpeciesProperties{c.species[k].ca, 0.0, c.species_membrane(k), c.species[k].shape});
  for (const CapsulePlacement& q : p) {
    EXPECT_NE(q.orientation, kIdentityRotation);
    s.add_capsule(q.center, c.species_radius(static_cast<std::size_t>(q.species)), q.species, q.orientation);
  }
  for (double y : s.y) {
    EXPECT_GE(y, 0.02 - 1e-9);
    EXPECT_LE(y, 8.0 - 0.02 + 1e-9);
  }
  const int nv = s.nodes_per_capsule();
  long closer_than_bounding = 0;
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::size_t j = 0; j < p.size(); ++j) {
      if (i == j) continue;
      const double ri = c.species_bounding_radius(static_cast<std::size_t>(p[i].species)),
                   rj = c.species_bounding_radius(static_cast<std::size_t>(p[j].species));
      const double dx = min_image(p[i].center[0] - p[j].center[0], 9.0), dy = p[i].center[1] - p[j].center[1],
                   dz = min_image(p[i].center[2] - p[j].center[2], 9.0);
      if (std::sqrt(dx * dx + dy * dy + dz * dz) >= ri + rj) continue;
      closer_than_bounding += i < j;
      // Capsule j's nodes, moved to the periodic image nearest capsule i.
      const double sx = p[i].center[0] - dx - p[j].center[0], sz = p[i].center[2] - dz - p[j].center[2];
      for (int v = 0; v < nv; ++v) {
        const std::size_t n = j * static_cast<std::size_t>(nv) + static_cast<std::size_t>(v);
        ASSERT_LT(winding_number(s, static_cast<int>(i), s.x[n] + sx, s.y[n], s.z[n] + sz), 0.5)
            << "node " << v << " of capsule " << j << " inside capsule " << i;
      }
    }
  EXPECT_GT(closer_than_bounding, 0);
}

// Per-species keys equal to the [capsules] values give today's run bit for bit: same placement (spheres are not
// turned and their positions come from the same draws), same step, same positions.
TEST(SpeciesPlacement, KeysEqualToTheDefaultsGiveTodaysBits) {
  const std::string base = box(9.0, 8.0) + "inflation = 0.1\n";
  const std::string tail = "[suspension]\nvolume_fraction = 0.1\nfractions = [0.5, 0.5]\nseed = 5\n[time]\nend = 1\n";
  const Config plain = parse_config(
      base + "[[species]]\nname = \"s\"\nca = 0.2\n[[species]]\nname = \"f\"\nca = 0.6\n" + tail, "a.toml");
  const Config keyed = parse_config(base + "[[species]]\nname = \"s\"\nca = 0.2\nradius = 1.0\nshape = \"sphere\"\n"
                                           "law = \"neo-hookean\"\ninflation = 0.1\nbending_modulus = 0\n"
                                           "[[species]]\nname = \"f\"\nca = 0.6\nradius = 1\n" + tail,
                                    "b.toml");
  Simulation a(plain), b(keyed);
  EXPECT_EQ(a.ca_step(), 0.2);
  EXPECT_EQ(b.ca_step(), 0.2);
  for (int k = 0; k < 3; ++k) {
    ASSERT_EQ(a.advance().stop, StopReason::None);
    ASSERT_EQ(b.advance().stop, StopReason::None);
  }
  const std::vector<double> pa = a.positions(), pb = b.positions();
  ASSERT_EQ(pa.size(), pb.size());
  EXPECT_EQ(std::memcmp(pa.data(), pb.data(), pa.size() * sizeof(double)), 0);
}

// The step rule's Ca: divided by the law's stiffness factor (exactly 1 for neo-Hookean) and scaled by a_ref / a.
TEST(SpeciesStepRule, TheRuleTakesTheStiffestCapsule) {
  EXPECT_EQ(step_stiffness_factor({MembraneLaw::NeoHookean, 1.0, 0.1}), 1.0);
  EXPECT_EQ(step_stiffness_factor({MembraneLaw::Skalak, 1.0, 0.0}), 1.0);      // same small-strain moduli
  EXPECT_EQ(step_stiffness_factor({MembraneLaw::Skalak, 0.5, 0.0}), 1.0);      // softer: never above NH's limit
  EXPECT_DOUBLE_EQ(step_stiffness_factor({MembraneLaw::Skalak, 10.0, 0.0}), 5.5);  // (2 + 2C) / 4
  // Prestressed: M(1.1) = 2.63 + 4.1047 C against 1 + 3 / 1.1^6 for neo-Hookean.
  const double l6 = std::pow(1.1, 6);
  EXPECT_NEAR(step_stiffness_factor({MembraneLaw::Skalak, 10.0, 0.1}),
              (3 * 1.21 - 1 + 10 * (3 * l6 - 1.21)) / (1 + 3 / l6), 1e-12);
  const std::string tail = "[[capsule]]\nspecies = \"a\"\ncenter = [4, 4, 4]\n[time]\nend = 1\n";
  Simulation sk(parse_config(box() + "[[species]]\nname = \"a\"\nca = 0.2\nlaw = \"skalak\"\nskalak_c = 10\n"
                                     "inflation = 0\n" + tail, "t.toml"));
  EXPECT_DOUBLE_EQ(sk.ca_step(), 0.2 / 5.5);
  Simulation small(parse_config(box() + "[[species]]\nname = \"a\"\nca = 0.2\nradius = 0.5\n" + tail, "t.toml"));
  EXPECT_DOUBLE_EQ(small.ca_step(), 0.4);  // a smaller capsule at equal Ca has a smaller Gs
}

// Volume of the level-`level` mesh of a shape at unit radius (signed tetrahedra from the origin).
double shape_mesh_volume(const ShapeSpec& shape, int level) {
  const TriMesh m = shape_mesh(shape, 1.0, level);
  double v = 0.0;
  for (std::size_t t = 0; t < m.tri.size() / 3; ++t) {
    const int a = m.tri[3 * t], b = m.tri[3 * t + 1], c = m.tri[3 * t + 2];
    v += (m.x[a] * (m.y[b] * m.z[c] - m.z[b] * m.y[c]) - m.y[a] * (m.x[b] * m.z[c] - m.z[b] * m.x[c]) +
          m.z[a] * (m.x[b] * m.y[c] - m.y[b] * m.x[c])) / 6.0;
  }
  return v;
}

// One red cell at rest (flow none): biconcave, Skalak C = 10, bending kb = 0.01, stress-free initial shape. Ca = 1
// makes the strain unit the membrane's relaxation time mu a / Gs.
Config resting_cell() {
  return parse_config(
      "[domain]\nH = 8\nLx = 8\nLz = 8\n[ggem]\nalpha = 4.0\nalpha_hm = 0.5\n[run]\nbackend = \"threads\"\n"
      "[flow]\ntype = \"none\"\n[capsules]\nmesh_level = 2\n"
      "[[species]]\nname = \"rbc\"\nca = 1.0\nshape = \"biconcave\"\nlaw = \"skalak\"\nskalak_c = 10\n"
      "inflation = 0\nbending_modulus = 0.01\n"
      "[[capsule]]\nspecies = \"rbc\"\ncenter = [4, 4, 4]\norientation = [0, 1, 1]\n[time]\nend = 10\n",
      "rbc.toml");
}

double max_distance(const std::vector<double>& a, const std::vector<double>& b) {
  double m = 0.0;
  for (std::size_t i = 0; i < a.size(); i += 3)
    m = std::max(m, std::hypot(a[i] - b[i], a[i + 1] - b[i + 1], a[i + 2] - b[i + 2]));
  return m;
}

// A red cell at rest keeps its shape and volume over 10 relaxation times mu a / Gs (it settles where its zero-
// spontaneous-curvature bending balances the shape memory, a small move); and a stretched one relaxes back to that
// shape, its elastic energy falling at every step.
TEST(SpeciesRuns, ARestingRedCellKeepsItsShapeAndAStretchedOneRelaxesBack) {
  const Config c = resting_cell();
  Simulation rest(c);
  const std::vector<double> x0 = rest.positions();
  const double V0 = rest.geometry().volume[0], A0 = rest.geometry().area[0];
  while (rest.time() < 10.0 - 1e-12) ASSERT_EQ(rest.advance().stop, StopReason::None);
  const std::vector<double> x_rest = rest.positions();
  const CapsuleGeometry g = rest.geometry();
  std::printf("resting cell: max move %.4g a, volume %.3g, area %.3g (relative) over %lld steps\n",
              max_distance(x0, x_rest), g.volume[0] / V0 - 1, g.area[0] / A0 - 1, static_cast<long long>(rest.step()));
  EXPECT_LT(max_distance(x0, x_rest), 0.05);
  EXPECT_NEAR(g.volume[0] / V0, 1.0, 1e-9);
  EXPECT_NEAR(g.area[0] / A0, 1.0, 5e-3);
  rest.evaluate();
  double umax = 0.0;
  for (std::size_t i = 0; i < rest.ux().size(); ++i)
    umax = std::max(umax, std::hypot(rest.ux()[i], rest.uy()[i], rest.uz()[i]));
  EXPECT_LT(umax, 1e-3);  // at rest

  // Stretched by 15 % along x (volume kept), it comes back to the resting shape.
  Simulation s(c);
  std::vector<double> x = s.positions();
  const double e = 1.15;
  for (std::size_t i = 0; i < x.size(); i += 3) {
    x[i] = 4.0 + e * (x[i] - 4.0);
    x[i + 1] = 4.0 + (x[i + 1] - 4.0) / std::sqrt(e);
    x[i + 2] = 4.0 + (x[i + 2] - 4.0) / std::sqrt(e);
  }
  s.set_positions(x);
  const double d0 = max_distance(s.positions(), x_rest);
  double E = s.state().membrane_energy()[0];
  while (s.time() < 10.0 - 1e-12) {
    ASSERT_EQ(s.advance().stop, StopReason::None);
    const double En = s.state().membrane_energy()[0];
    ASSERT_LT(En, E * (1 + 1e-12)) << "at strain " << s.time();
    E = En;
  }
  const double d1 = max_distance(s.positions(), x_rest);
  std::printf("stretched cell: distance from the resting shape %.4g -> %.4g a\n", d0, d1);
  EXPECT_LT(d1, 0.1 * d0);  // measured 0.058: the slowest mode is bending's, time mu a^3 / kappa = 100 mu a / Gs
}

// With mixed sizes the analysis's X_f is the floppy share of the nominal volume (equal sizes: the number fraction).
TEST(SpeciesAnalysis, FloppyFractionIsAVolumeShareWithMixedSizes) {
  analysis::RunSeries r;
  r.np = 4;
  r.ca = {0.03, 0.3, 0.3, 0.3};
  analysis::RunGroup g;
  g.ca = {0.03, 0.3};
  g.runs = {r};
  EXPECT_EQ(analysis::floppy_fraction(g), 0.75);
  g.runs[0].capsule_radius = {0.5, 1.0, 1.0, 1.0};
  EXPECT_DOUBLE_EQ(analysis::floppy_fraction(g), 3.0 / 3.125);
}

// Red cells (biconcave, Skalak, bending) with platelets (small oblate spheroids) at random orientations: the run
// restarts bit for bit from a checkpoint (the orientations are stored with it), and `capsflow analyze` reads it.
TEST(SpeciesRuns, AMixedSizeSuspensionRunsRestartsBitForBitAndAnalyses) {
  test::TempDir dir;
  const Config cfg = parse_config(mixed_suspension(), "mixed.toml");
  std::ostringstream sink;
  const RunResult full = run_simulation(cfg, test::quiet_run(dir.path / "full.h5"), sink);
  ASSERT_EQ(full.exit_code, 0) << full.stop_message;
  ASSERT_GE(full.steps, 6);
  RunSettings first = test::quiet_run(dir.path / "part.h5");
  first.stop_after_steps = full.steps / 2 + 1;
  const RunResult part = run_simulation(cfg, first, sink);
  EXPECT_EQ(part.exit_code, 128 + SIGINT);
  EXPECT_TRUE(H5File::open(part.checkpoint).exists("/state/initial_orientations"));
  RunSettings cont;
  cont.restart = part.checkpoint;
  cont.quiet = true;
  const RunResult rest = run_simulation(cfg, cont, sink);
  ASSERT_EQ(rest.exit_code, 0) << rest.stop_message;
  EXPECT_EQ(part.steps + rest.steps, full.steps);
  const H5File a = H5File::open(dir.path / "full.h5"), b = H5File::open(dir.path / "part.h5");
  for (const char* p : {"/series/time", "/series/centroid", "/series/velocity", "/series/volume", "/frames/positions"})
    test::expect_same_dataset(a, b, p);

  // Volumes: each capsule keeps its initial (discrete) volume (the volume correction), and the initial volumes follow
  // the species' radii: platelets / cells = (0.55)^3 times the ratio of their level-1 polyhedra's volume factors.
  const auto vol = a.read<double>("/series/volume");
  const auto species = a.read<std::int32_t>("/capsules/species");
  const std::size_t np = species.data.size(), nrec = vol.data.size() / np;
  ASSERT_GE(nrec, 3u);
  for (std::size_t k = 0; k < np; ++k)
    EXPECT_NEAR(vol.data[(nrec - 1) * np + k] / vol.data[k], 1.0, 1e-9) << k;
  double vcell = 0.0, vplatelet = 0.0;
  for (std::size_t k = 0; k < np; ++k) (species.data[k] == 0 ? vcell : vplatelet) = vol.data[k];
  ASSERT_GT(vcell * vplatelet, 0.0);
  const double f_cell = shape_mesh_volume({ShapeKind::Biconcave}, 1);
  const double f_pl = shape_mesh_volume({ShapeKind::Spheroid, 0.4}, 1);
  EXPECT_NEAR(vplatelet / vcell, std::pow(0.55, 3) * f_pl / f_cell, 1e-12);

  const test::CliResult r = test::run_capsflow(dir.path, "analyze full.h5 --out an --window 0:0.12 -q", 300);
  ASSERT_EQ(r.status, 0) << r.err << r.out;
  EXPECT_TRUE(fs::exists(dir.path / "an" / "analysis.h5"));
}

}  // namespace
