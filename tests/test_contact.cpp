// Overlap / contact control (method-spec 8.3, decision D5): rigid pair and wall pushes, periodic images,
// untouched configurations, statistics, backend agreement.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <ostream>
#include <vector>

#include "host/capsule_state.hpp"
#include "host/contact.hpp"
#include "host/errors.hpp"
#include "kernels/ggem_kernels.hpp"
#include "support/backends.hpp"

using namespace capsflow;

namespace capsflow {
inline void PrintTo(Backend b, std::ostream* os) { *os << backend_name(b); }
}  // namespace capsflow

namespace {

constexpr double kGap = 0.02;
constexpr double kLx = 8.0, kLz = 6.0, kH = 6.0;

using Vec3 = std::array<double, 3>;

Vec3 node_mean(const CapsuleState& s, int k) {
  const int nv = s.nodes_per_capsule();
  Vec3 c{0, 0, 0};
  for (int i = k * nv; i < (k + 1) * nv; ++i) {
    c[0] += s.x[i];
    c[1] += s.y[i];
    c[2] += s.z[i];
  }
  for (double& v : c) v /= nv;
  return c;
}

// Independent check: smallest node-node distance (minimum image in x, z) between capsules a and b, brute force.
double min_node_distance(const CapsuleState& s, int a, int b) {
  const int nv = s.nodes_per_capsule();
  double r2 = 1e300;
  for (int i = a * nv; i < (a + 1) * nv; ++i)
    for (int j = b * nv; j < (b + 1) * nv; ++j) {
      const double dx = min_image(s.x[i] - s.x[j], kLx), dy = s.y[i] - s.y[j], dz = min_image(s.z[i] - s.z[j], kLz);
      r2 = std::min(r2, dx * dx + dy * dy + dz * dz);
    }
  return std::sqrt(r2);
}

double min_y(const CapsuleState& s, int k) {
  const int nv = s.nodes_per_capsule();
  double m = 1e300;
  for (int i = k * nv; i < (k + 1) * nv; ++i) m = std::min(m, s.y[i]);
  return m;
}

double max_y(const CapsuleState& s, int k) {
  const int nv = s.nodes_per_capsule();
  double m = -1e300;
  for (int i = k * nv; i < (k + 1) * nv; ++i) m = std::max(m, s.y[i]);
  return m;
}

// Translation of capsule k between `before` and `after`; fails the test unless it is rigid to 1e-12.
Vec3 rigid_translation(const CapsuleState& before, const CapsuleState& after, int k) {
  const int nv = before.nodes_per_capsule();
  const int i0 = k * nv;
  const Vec3 t{after.x[i0] - before.x[i0], after.y[i0] - before.y[i0], after.z[i0] - before.z[i0]};
  double dev = 0.0;
  for (int i = i0; i < i0 + nv; ++i) {
    dev = std::max(dev, std::abs(after.x[i] - before.x[i] - t[0]));
    dev = std::max(dev, std::abs(after.y[i] - before.y[i] - t[1]));
    dev = std::max(dev, std::abs(after.z[i] - before.z[i] - t[2]));
  }
  EXPECT_LT(dev, 1e-12) << "capsule " << k << " deformed or rotated";
  return t;
}

CapsuleState two_spheres(const Vec3& a, const Vec3& b) {
  CapsuleState s(2);
  const int sp = s.add_species(0.3);
  s.add_capsule(a, 1.0, sp);
  s.add_capsule(b, 1.0, sp);
  return s;
}

void translate(CapsuleState& s, int k, const Vec3& t) {
  const int nv = s.nodes_per_capsule();
  for (int i = k * nv; i < (k + 1) * nv; ++i) {
    s.x[i] += t[0];
    s.y[i] += t[1];
    s.z[i] += t[2];
  }
}

class Contact : public ::testing::TestWithParam<Backend> {};

TEST_P(Contact, OverlappingSpheresSeparateRigidlyAlongTheLineOfCentres) {
  CAPSFLOW_SKIP_IF_UNAVAILABLE(GetParam());
  // Oblique line of centres, 0.25 interpenetration.
  const Vec3 ca{3.0, 3.0, 3.0}, cb{3.0 + 1.75 * 0.8, 3.0 + 1.75 * 0.36, 3.0 + 1.75 * 0.48};
  CapsuleState s = two_spheres(ca, cb);
  const CapsuleState before = s;
  const ContactStats st = resolve_contacts(s, kLx, kLz, kH, kGap, GetParam());
  std::printf("[contact] overlap 0.25: iterations %d, pair corrections %ld, initial gap %.4g, final gap %.6g\n",
              st.iterations, st.pair_corrections, st.initial_min_gap, st.final_min_gap);
  EXPECT_TRUE(st.converged);
  EXPECT_GE(st.iterations, 1);
  EXPECT_GE(st.pair_corrections, st.iterations);
  EXPECT_EQ(st.wall_corrections, 0);
  EXPECT_LT(st.initial_min_gap, 0.0);  // an overlap is a negative gap
  EXPECT_GE(st.final_min_gap, kGap);

  EXPECT_GE(min_node_distance(s, 0, 1), kGap * (1.0 - 1e-9));
  const Vec3 ta = rigid_translation(before, s, 0), tb = rigid_translation(before, s, 1);
  // Symmetric: ta = -tb; along the line of centres: ta parallel to (ca - cb), pointing away from b.
  const Vec3 e{ca[0] - cb[0], ca[1] - cb[1], ca[2] - cb[2]};
  const double el = std::sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
  const double along = (ta[0] * e[0] + ta[1] * e[1] + ta[2] * e[2]) / el;
  EXPECT_GT(along, 0.1);
  for (int d = 0; d < 3; ++d) {
    EXPECT_NEAR(ta[d], -tb[d], 1e-12);
    EXPECT_NEAR(ta[d], along * e[d] / el, 1e-12);
  }
  // Centres now at least two radii apart (no sphere interpenetration).
  const Vec3 ma = node_mean(s, 0), mb = node_mean(s, 1);
  EXPECT_GT(std::hypot(ma[0] - mb[0], ma[1] - mb[1], ma[2] - mb[2]), 2.0 - 1e-3);
}

TEST_P(Contact, InterpenetrationAcrossThePeriodicXBoundary) {
  CAPSFLOW_SKIP_IF_UNAVAILABLE(GetParam());
  // Centres 0.3 and 7.9: 0.4 apart through x = 0 = Lx, deep overlap.
  CapsuleState s = two_spheres({0.3, 3.0, 3.0}, {7.9, 3.0, 3.0});
  const CapsuleState before = s;
  const ContactStats st = resolve_contacts(s, kLx, kLz, kH, kGap, GetParam());
  std::printf("[contact] periodic overlap 1.6: iterations %d, pair corrections %ld, initial gap %.4g, final %.6g\n",
              st.iterations, st.pair_corrections, st.initial_min_gap, st.final_min_gap);
  EXPECT_TRUE(st.converged);
  EXPECT_GE(st.final_min_gap, kGap);
  EXPECT_GE(min_node_distance(s, 0, 1), kGap * (1.0 - 1e-9));
  const Vec3 ta = rigid_translation(before, s, 0), tb = rigid_translation(before, s, 1);
  // The capsule at 0.3 moves to +x (away from its image neighbour at -0.1), the other to -x.
  EXPECT_GT(ta[0], 0.5);
  EXPECT_LT(tb[0], -0.5);
  EXPECT_NEAR(ta[0], -tb[0], 1e-12);
  for (int d = 1; d < 3; ++d) {
    EXPECT_NEAR(ta[d], 0.0, 1e-12);
    EXPECT_NEAR(tb[d], 0.0, 1e-12);
  }
  const Vec3 ma = node_mean(s, 0), mb = node_mean(s, 1);
  EXPECT_GT(std::abs(min_image(ma[0] - mb[0], kLx)), 2.0 - 1e-3);
}

TEST_P(Contact, CapsuleNearTheBottomWallIsPushedAwayAlongY) {
  CAPSFLOW_SKIP_IF_UNAVAILABLE(GetParam());
  CapsuleState s(2);
  s.add_capsule({4.0, 2.0, 3.0}, 1.0, s.add_species(0.3));
  translate(s, 0, {0.0, 0.005 - min_y(s, 0), 0.0});  // lowest node 0.005 above y = 0
  const CapsuleState before = s;
  const ContactStats st = resolve_contacts(s, kLx, kLz, kH, kGap, GetParam());
  std::printf("[contact] wall 0.005: iterations %d, wall corrections %ld, final gap %.6g\n", st.iterations,
              st.wall_corrections, st.final_min_gap);
  EXPECT_TRUE(st.converged);
  EXPECT_EQ(st.iterations, 1);
  EXPECT_EQ(st.wall_corrections, 1);
  EXPECT_EQ(st.pair_corrections, 0);
  EXPECT_NEAR(st.initial_min_gap, 0.005, 1e-12);
  EXPECT_GE(min_y(s, 0), kGap - 1e-12);
  EXPECT_LT(min_y(s, 0), 1.1 * kGap);  // pushed by the deficit (plus the 1 % margin), not further
  const Vec3 t = rigid_translation(before, s, 0);
  EXPECT_GT(t[1], 0.0);
  EXPECT_EQ(t[0], 0.0);
  EXPECT_EQ(t[2], 0.0);
}

TEST_P(Contact, CapsuleInTheTopWallIsPushedDown) {
  CAPSFLOW_SKIP_IF_UNAVAILABLE(GetParam());
  CapsuleState s(2);
  s.add_capsule({4.0, 4.0, 3.0}, 1.0, s.add_species(0.3));
  translate(s, 0, {0.0, kH + 0.05 - max_y(s, 0), 0.0});  // top node 0.05 beyond the wall
  const ContactStats st = resolve_contacts(s, kLx, kLz, kH, kGap, GetParam());
  EXPECT_TRUE(st.converged);
  EXPECT_EQ(st.wall_corrections, 1);
  EXPECT_LE(max_y(s, 0), kH - kGap + 1e-12);
}

TEST_P(Contact, ConfigurationWithoutViolationsIsUntouched) {
  CAPSFLOW_SKIP_IF_UNAVAILABLE(GetParam());
  // Spheres 2.05 apart (node gap >= 0.05) and 0.5 from the walls.
  CapsuleState s = two_spheres({3.0, 3.0, 3.0}, {5.05, 3.0, 3.0});
  const CapsuleState before = s;
  const ContactStats st = resolve_contacts(s, kLx, kLz, kH, kGap, GetParam());
  EXPECT_TRUE(st.converged);
  EXPECT_EQ(st.iterations, 0);
  EXPECT_EQ(st.pair_corrections, 0);
  EXPECT_EQ(st.wall_corrections, 0);
  EXPECT_EQ(st.max_displacement, 0.0);
  EXPECT_GE(st.final_min_gap, kGap);
  EXPECT_EQ(st.initial_min_gap, st.final_min_gap);
  EXPECT_TRUE(s.x == before.x);
  EXPECT_TRUE(s.y == before.y);
  EXPECT_TRUE(s.z == before.z);
}

// A crowded cluster: overlapping pairs, a capsule pressed into the wall by its neighbour, periodic neighbours.
CapsuleState cluster() {
  CapsuleState s(2);
  const int sp = s.add_species(0.3);
  const Vec3 c[] = {{1.0, 1.01, 1.0}, {2.7, 1.2, 1.3}, {1.9, 2.6, 1.2}, {7.2, 1.6, 1.1},
                    {4.4, 2.0, 2.2}, {1.4, 1.3, 5.2}, {3.6, 4.9, 3.0}, {5.0, 4.0, 3.9}};
  for (const Vec3& ci : c) s.add_capsule(ci, 1.0, sp);
  return s;
}

TEST_P(Contact, CrowdedClusterConvergesAndMatchesSerialBitwise) {
  CAPSFLOW_SKIP_IF_UNAVAILABLE(GetParam());
  CapsuleState ref = cluster(), s = cluster();
  const ContactStats sr = resolve_contacts(ref, kLx, kLz, kH, kGap, Backend::Serial);
  const ContactStats st = resolve_contacts(s, kLx, kLz, kH, kGap, GetParam());
  std::printf("[contact] cluster of 8: iterations %d, pair corrections %ld, wall corrections %ld, initial %.4g, "
              "final %.6g\n",
              st.iterations, st.pair_corrections, st.wall_corrections, st.initial_min_gap, st.final_min_gap);
  EXPECT_TRUE(st.converged);
  EXPECT_GT(st.pair_corrections, 0);
  EXPECT_GT(st.wall_corrections, 0);
  EXPECT_TRUE(s.x == ref.x);
  EXPECT_TRUE(s.y == ref.y);
  EXPECT_TRUE(s.z == ref.z);
  EXPECT_EQ(st.iterations, sr.iterations);
  EXPECT_EQ(st.pair_corrections, sr.pair_corrections);
  EXPECT_EQ(st.wall_corrections, sr.wall_corrections);
  EXPECT_EQ(st.final_min_gap, sr.final_min_gap);
  const CapsuleState c0 = cluster();
  for (int a = 0; a < s.num_capsules(); ++a) {
    rigid_translation(c0, s, a);
    EXPECT_GE(min_y(s, a), kGap - 1e-12);
    EXPECT_LE(max_y(s, a), kH - kGap + 1e-12);
    for (int b = a + 1; b < s.num_capsules(); ++b) EXPECT_GE(min_node_distance(s, a, b), kGap * (1.0 - 1e-9));
  }
}

INSTANTIATE_TEST_SUITE_P(Backends, Contact, ::testing::Values(Backend::Serial, Backend::Threads, Backend::Device),
                         test::backend_param_name);

TEST(ContactAmit, AmitRuleApproachesTheGapSlowly) {
  CapsuleState s = two_spheres({3.0, 3.0, 3.0}, {4.9, 3.0, 3.0});
  const CapsuleState before = s;
  const ContactStats st = resolve_contacts(s, kLx, kLz, kH, kGap, Backend::Serial, 1000, ContactRule::Amit);
  std::printf("[contact] Amit rule, overlap 0.1: converged %d, iterations %d, pairs %ld, initial %.4g, final %.10g\n",
              st.converged ? 1 : 0, st.iterations, st.pair_corrections, st.initial_min_gap, st.final_min_gap);
  // Rigid and symmetric whatever the convergence.
  const Vec3 ta = rigid_translation(before, s, 0), tb = rigid_translation(before, s, 1);
  EXPECT_NEAR(ta[0], -tb[0], 1e-12);
  EXPECT_LT(ta[0], 0.0);
  // Either it reached the gap, or it says it did not (final gap below min_gap, all iterations used).
  if (st.converged) {
    EXPECT_GE(st.final_min_gap, kGap);
  } else {
    EXPECT_LT(st.final_min_gap, kGap);
    EXPECT_EQ(st.iterations, 1000);
  }
  EXPECT_GT(st.final_min_gap, 0.9 * kGap);  // no overlap left
}

TEST(ContactLimits, NonConvergenceIsReported) {
  // max_iterations = 1 cannot resolve a 0.3 overlap with Amit's small steps.
  CapsuleState s = two_spheres({3.0, 3.0, 3.0}, {4.7, 3.0, 3.0});
  const ContactStats st = resolve_contacts(s, kLx, kLz, kH, kGap, Backend::Serial, 1, ContactRule::Amit);
  EXPECT_FALSE(st.converged);
  EXPECT_EQ(st.iterations, 1);
  EXPECT_LT(st.final_min_gap, kGap);

  // A capsule taller than the slit cannot satisfy both walls.
  CapsuleState t(2);
  t.add_capsule({4.0, 1.0, 3.0}, 1.0, t.add_species(0.3));
  const ContactStats sw = resolve_contacts(t, kLx, kLz, 2.0, kGap, Backend::Serial, 20);
  EXPECT_FALSE(sw.converged);
  EXPECT_EQ(sw.iterations, 20);
}

TEST(ContactLimits, BadInputsThrow) {
  CapsuleState s = two_spheres({3.0, 3.0, 3.0}, {5.5, 3.0, 3.0});
  EXPECT_THROW((void)resolve_contacts(s, kLx, kLz, kH, 0.0, Backend::Serial), InputError);
  EXPECT_THROW((void)resolve_contacts(s, kLx, kLz, -1.0, kGap, Backend::Serial), InputError);
  EXPECT_THROW((void)resolve_contacts(s, kLx, kLz, kH, kGap, Backend::Serial, -1), InputError);
}

}  // namespace
